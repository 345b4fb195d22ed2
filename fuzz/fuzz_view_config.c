/* libFuzzer: horizon view's `key = value` config file (view_config_read).
 * Every accepted line becomes "--key" (+ value) tokens that the option
 * parser then accepts or refuses with a message; nothing crashes or leaks. */
#include <string.h>

#include "cli.h"
#include "fuzz_util.h"
#include "view_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *file = fuzz_tmp_file("view.conf", data, size);
    if (!file)
        return 0;
    strlist l = {0};
    int rc = view_config_read(file, &l, size % 2 == 0);
    if (rc == 0) {
        for (size_t k = 0; k < l.count; k++)
            if (!l.s[k] || (k == 0 && strncmp(l.s[k], "--", 2)))
                abort();
        /* Through the shared parser, as horizon view does. */
        char **argv = calloc(l.count + 3, sizeof *argv);
        if (argv) {
            argv[0] = (char *)"horizon";
            argv[1] = (char *)"view";
            for (size_t k = 0; k < l.count; k++)
                argv[k + 2] = l.s[k];
            cli_opts o;
            (void)cli_parse((int)l.count + 2, argv, 2, &o, "view");
            free(argv);
        }
    } else if (rc != 1 && rc != 2) {
        abort();
    }
    strlist_free(&l);
    unlink(file);
    return 0;
}
