#!/usr/bin/env bash
# horizon view with objects (issue 13): OGR footprints on the Heidelberg DEM,
# a scripted click on a building prints its node, attributes and CRS / lon-lat
# position, and the HUD counts the objects. Runs under scripts/with-xvfb.sh,
# whose 1280x1024 screen puts the pointer at its centre (640, 512) first.
set -u
HZ="$1"; DATA="$2"; TMP="$3"
mkdir -p "$TMP"
cat > "$TMP/hd.geojson" <<'GJ'
{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{"osm_id":4711,"height":15},"geometry":{"type":"Polygon","coordinates":[[[8.69,49.41],[8.6903,49.41],[8.6903,49.4102],[8.69,49.4102],[8.69,49.41]]]}},
{"type":"Feature","properties":{"osm_id":4712,"building:levels":"3"},"geometry":{"type":"Polygon","coordinates":[[[8.6906,49.41],[8.6908,49.41],[8.6908,49.4101],[8.6906,49.4101],[8.6906,49.41]]]}}]}
GJ
# From the pointer's start (640, 512) to the big building's pixel (540, 300), then click.
printf '1 mouse -100 -212\n2 button left down\n3 button left up\n' > "$TMP/click.txt"
out=$("$HZ" view --quiet --dem "$DATA/heidelberg_dem_hd_utm32n_25m_float32.tif" --footprints "$TMP/hd.geojson" \
      --effects none --frames 8 --script "$TMP/click.txt" --width 1280 --height 720 --screenshot "$TMP/click.png" 2>&1)
rc=$?
echo "$out"
fails=0
if [ $rc -eq 0 ] && echo "$out" | grep -q '^pick          540,300: 4711 {"osm_id":4711' &&
   echo "$out" | grep -Eq '^pick lon/lat  8\.690[0-3][0-9]*, 49\.410[01]'; then
  echo "ok   a click on the building prints it, its attributes and its lon/lat"
else
  echo "FAIL click pick (exit $rc)"; fails=1
fi
[ -s "$TMP/click.png" ] && echo "ok   screenshot" || { echo "FAIL no screenshot"; fails=1; }
echo "$((2 - fails)) passed, $fails failed"
exit $fails
