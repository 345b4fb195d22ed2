#!/bin/sh
# Doxygen input filter: the headers document with plain /* */ comments; read
# each comment that opens a line as a /** */ doc comment.
exec sed -e 's|^\([[:space:]]*\)/\* |\1/** |' "$1"
