#!/usr/bin/env bash
# libhorizon as a C programmer gets it: `cmake --install` into a scratch
# prefix, then the three examples built against that prefix only, once with
# pkg-config and once with find_package(horizon), and run.
#   test_install.sh BUILD_DIR SOURCE_DIR TMP DATA_DIR
set -u
BUILD="$1"; SRC="$2"; TMP="$3"; DATA="$4"
fails=0; passes=0
ok()  { passes=$((passes+1)); echo "ok   $*"; }
bad() { fails=$((fails+1)); echo "FAIL $*"; }
rm -rf "$TMP"; mkdir -p "$TMP"
PREFIX="$TMP/prefix"
if cmake --install "$BUILD" --prefix "$PREFIX" >"$TMP/install.log" 2>&1; then ok "cmake --install"; else bad "cmake --install: $(tail -5 "$TMP/install.log")"; fi
LIB=$(ls -d "$PREFIX"/lib* | head -1)
for f in include/horizon/terrain.h include/horizon/render.h include/horizon/climate.h; do
  [ -f "$PREFIX/$f" ] && ok "installed $f" || bad "missing $f"
done
[ -f "$LIB/libhorizon.a" ] && ok "installed libhorizon.a" || bad "missing libhorizon.a"
[ -e "$LIB/libhorizon.so" ] && ok "installed libhorizon.so" || bad "missing libhorizon.so"
[ -f "$LIB/pkgconfig/horizon.pc" ] && ok "installed horizon.pc" || bad "missing horizon.pc"
[ -f "$LIB/cmake/horizon/horizonConfig.cmake" ] && ok "installed horizonConfig.cmake" || bad "missing horizonConfig.cmake"

# Every public header compiles on its own, as C99 and C11, without warnings.
for h in "$PREFIX"/include/horizon/*.h; do
  for std in c99 c11; do
    if ! echo "#include <horizon/$(basename "$h")>" | cc -std=$std -Wall -Wextra -Werror -fsyntax-only \
         $(PKG_CONFIG_PATH="$LIB/pkgconfig" pkg-config --cflags horizon) -x c - 2>"$TMP/hdr.err"; then
      bad "header $(basename "$h") alone ($std): $(head -3 "$TMP/hdr.err")"
      continue 2
    fi
  done
done
[ $fails -eq 0 ] && ok "every public header is self-contained (c99, c11)"

# pkg-config: the examples against the prefix, nothing from the source tree.
export PKG_CONFIG_PATH="$LIB/pkgconfig"
for ex in dem_query render_png fly_path; do
  if cc -std=c11 -Wall -Wextra -Werror "$SRC/examples/$ex.c" $(pkg-config --cflags --libs horizon) -o "$TMP/$ex" \
       2>"$TMP/$ex.err"; then ok "pkg-config build: $ex"; else bad "pkg-config build $ex: $(head -5 "$TMP/$ex.err")"; fi
done
export LD_LIBRARY_PATH="$LIB${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
out=$("$TMP/dem_query" "$DATA/N44W072.hgt" -71.3033 44.2706 2>&1)
echo "$out" | grep -Eq "height 1[89][0-9][0-9]\.[0-9]+ m" && ok "dem_query: Mount Washington's height by lon/lat" || bad "dem_query: $out"
out=$("$TMP/render_png" "$TMP/frame.png" 2>&1)
[ -s "$TMP/frame.png" ] && echo "$out" | grep -q "triangles" && ok "render_png: $out" || bad "render_png: $out"
out=$("$TMP/fly_path" 3 2>&1)
echo "$out" | grep -Eq "^median +[1-9]" && ok "fly_path: $(echo "$out" | tail -1)" || bad "fly_path: $out"

# CMake: find_package(horizon) from the prefix.
mkdir -p "$TMP/cm"
cat > "$TMP/cm/CMakeLists.txt" <<CM
cmake_minimum_required(VERSION 3.20)
project(use_horizon C)
find_package(horizon 0.1 REQUIRED)
add_executable(dem_query "$SRC/examples/dem_query.c")
target_link_libraries(dem_query PRIVATE horizon::horizon)
CM
if cmake -S "$TMP/cm" -B "$TMP/cm/build" -DCMAKE_PREFIX_PATH="$PREFIX" >"$TMP/cm.log" 2>&1 &&
   cmake --build "$TMP/cm/build" >>"$TMP/cm.log" 2>&1 &&
   "$TMP/cm/build/dem_query" "$DATA/N44W072.hgt" | grep -q "height"; then
  ok "find_package(horizon): dem_query builds and runs"
else
  bad "find_package(horizon): $(tail -8 "$TMP/cm.log")"
fi
echo "test_install: $passes passed, $fails failed"
[ $fails -eq 0 ]
