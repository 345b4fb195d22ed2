"""Shared by tests/cli/test_http.py and bench/http_bench.py: a real nginx started
on 127.0.0.1 on a free port from a config written into a folder of the
caller's (no root paths), and a faulty / slow proxy in front of it."""
import http.client, http.server, os, shutil, socket, subprocess, threading, time

NGINX = shutil.which("nginx") or "/usr/sbin/nginx"


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def wait_port(port, secs=10):
    end = time.time() + secs
    while time.time() < end:
        try:
            socket.create_connection(("127.0.0.1", port), 0.2).close()
            return True
        except OSError:
            time.sleep(0.05)
    return False


class Nginx:
    """Stock nginx serving the folder www on 127.0.0.1 on a free port, from a
    config written in d (pid, logs and temp folders there too); url is that
    of the file name."""

    def __init__(self, www, d, name="x.hzp"):
        self.port = free_port()
        os.makedirs(d, exist_ok=True)
        self.log = os.path.join(d, "access.log")
        conf = os.path.join(d, "nginx.conf")
        with open(conf, "w") as f:
            # started as root, nginx's workers would drop to nobody, who cannot read a
            # checkout in a private folder (mktemp -d): they run as the test's user
            f.write(("user %s;\n" % __import__("pwd").getpwuid(os.getuid()).pw_name if os.getuid() == 0 else "") +
                    """worker_processes 1;
pid %(d)s/nginx.pid;
error_log %(d)s/error.log;
daemon off;
events { worker_connections 256; }
http {
  log_format conn '$connection $connection_requests $status $http_range $body_bytes_sent';
  access_log %(d)s/access.log conn;
  client_body_temp_path %(d)s/body; proxy_temp_path %(d)s/proxy; fastcgi_temp_path %(d)s/fcgi;
  uwsgi_temp_path %(d)s/uwsgi; scgi_temp_path %(d)s/scgi;
  types { application/octet-stream hzp; }
  server {
    listen 127.0.0.1:%(port)d;
    root %(www)s;
    location ~ \\.hzp$ { add_header Cache-Control "public, max-age=86400, immutable"; }
  }
}
""" % {"d": d, "port": self.port, "www": www})
        self.p = subprocess.Popen([NGINX, "-c", conf, "-p", d + "/", "-e", os.path.join(d, "error.log")],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        if not wait_port(self.port):
            self.stop()
            raise RuntimeError("nginx did not start: " + self.p.stderr.read().decode())
        self.url = "http://127.0.0.1:%d/%s" % (self.port, name)

    def log_lines(self):
        return [l.split() for l in open(self.log)] if os.path.exists(self.log) else []

    def stop(self):
        if self.p.poll() is None:
            self.p.terminate()
            try:
                self.p.wait(10)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()



class Proxy(http.server.ThreadingHTTPServer):
    """Forwards GETs to nginx (after `latency` s each). mode:
    pass    - as nginx answers
    flaky   - per range asked: attempt 1 -> 500, 2 -> dropped mid-body,
              3 -> answer after `delay` s, 4 on -> the right bytes
    fail1   - ranges starting at an offset in `targets` always 500, the rest as nginx answers
    corrupt1 - ranges starting at an offset in `targets` with one byte flipped
    norange - 200 and the whole file (a server ignoring ranges)"""
    daemon_threads = True

    def __init__(self, upstream_port, mode, delay=2.0, targets=(), latency=0.0, name="x.hzp"):
        self.upstream, self.mode, self.delay = upstream_port, mode, delay
        self.targets, self.latency = set(targets), latency
        self.attempts, self.lock, self.counts = {}, threading.Lock(), {}
        self.inflight = self.max_inflight = 0  # requests being answered at once
        super().__init__(("127.0.0.1", 0), ProxyHandler)
        self.port = self.server_address[1]
        self.url = "http://127.0.0.1:%d/%s" % (self.port, name)
        self.t = threading.Thread(target=self.serve_forever, daemon=True)
        self.t.start()

    def handle_error(self, request, client_address):
        pass  # the client closing a connection it timed out on is part of the test

    def count(self, what):
        with self.lock:
            self.counts[what] = self.counts.get(what, 0) + 1

    def stop(self):
        self.shutdown()
        self.server_close()


class ProxyHandler(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    disable_nagle_algorithm = True  # headers and body go in two writes: no 40 ms delayed-ACK stall

    def log_message(self, *a):
        pass

    def do_GET(self):
        srv = self.server
        with srv.lock:
            srv.inflight += 1
            srv.max_inflight = max(srv.max_inflight, srv.inflight)
        try:
            self.answer(srv)
        finally:
            with srv.lock:
                srv.inflight -= 1

    def answer(self, srv):
        rng = self.headers.get("Range", "")
        start = int(rng[6:].split("-")[0]) if rng.startswith("bytes=") else -1
        with srv.lock:
            n = srv.attempts[rng] = srv.attempts.get(rng, 0) + 1
        if srv.latency:
            time.sleep(srv.latency)
        if srv.mode == "flaky" and n == 1 or srv.mode == "fail1" and start in srv.targets:
            srv.count("500")
            body = b"<html>internal error</html>"
            self.send_response(500)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)
            return
        if srv.mode == "flaky" and n == 3:
            srv.count("delay")
            time.sleep(srv.delay)
        up = http.client.HTTPConnection("127.0.0.1", srv.upstream, timeout=10)
        up.request("GET", self.path, headers={} if srv.mode == "norange" else {"Range": rng})
        r = up.getresponse()
        body = r.read()
        up.close()
        if srv.mode == "corrupt1" and start in srv.targets and len(body) > 100:
            srv.count("corrupt")
            body = body[:100] + bytes([body[100] ^ 0x5A]) + body[101:]
        try:
            self.send_response(r.status)
            for h in ("Content-Range", "ETag", "Last-Modified", "Accept-Ranges"):
                if r.getheader(h):
                    self.send_header(h, r.getheader(h))
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            if srv.mode == "flaky" and n == 2:
                srv.count("drop")
                self.wfile.write(body[: len(body) // 2])
                self.wfile.flush()
                self.close_connection = True
                self.connection.shutdown(socket.SHUT_RDWR)
                return
            self.wfile.write(body)
        except (BrokenPipeError, ConnectionResetError):
            self.close_connection = True
