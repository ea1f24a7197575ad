#!/usr/bin/env bash
# The Debian package, as an installer gets it (docs/install.md): CPack builds it from the build
# tree, lintian reports no error, and its contents unpacked into a throwaway root (dpkg-deb -x)
# work there alone: the examples copied out of it are baked, verified, shaded and run through the
# live service headless for 30 frames, by the unpacked programs with the unpacked shaders and
# presets (none of them names the source tree); systemd-analyze verify accepts its units.
# Registered as the CTest Package.Debian.
#
#   bash tests/install/check_package.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
source=$(cd "$2" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/skylit_package_XXXXXX")
trap 'rm -rf "$work"' EXIT
say() { echo "check_package: $*"; }
fail() { echo "check_package: $*" >&2; exit 1; }

# The package, written to a folder of its own so that a `make package` beside it is not disturbed.
cpack --config "$build/CPackConfig.cmake" -B "$work/out" > "$work/cpack.log" 2>&1 || { cat "$work/cpack.log" >&2; fail "cpack failed"; }
version=$(sed -n 's/^project(skylit VERSION \([0-9.]*\).*/\1/p' "$source/CMakeLists.txt")
deb="$work/out/skylit_${version}_amd64.deb"
[[ -f "$deb" ]] || fail "no $deb (cpack wrote: $(ls "$work/out"))"
say "$(basename "$deb"): $(du -h "$deb" | cut -f1)"

dpkg-deb --field "$deb" Package Version Architecture Depends > "$work/control"
grep -q '^Depends:.*libc6' "$work/control" || fail "Depends lacks the libraries dpkg-shlibdeps finds: $(cat "$work/control")"
grep -q '^Depends:.*libopencv' "$work/control" || fail "Depends lacks OpenCV: $(cat "$work/control")"
grep -q '^Depends:.*adduser' "$work/control" || fail "Depends lacks adduser (postinst): $(cat "$work/control")"

# lintian: errors fail; warnings and notes are printed for whoever reads the log.
if ! lintian --fail-on error --tag-display-limit 0 "$deb" > "$work/lintian.log" 2>&1; then
  cat "$work/lintian.log" >&2
  fail "lintian reports errors"
fi
say "lintian: no errors; $(grep -c '^W:' "$work/lintian.log" || true) warnings:"
sed -n 's/^W: /  /p' "$work/lintian.log"

root="$work/root"
dpkg-deb -x "$deb" "$root"
for file in usr/bin/skylit-bake usr/bin/skylit-live usr/bin/skylit-sky-node usr/bin/skylit-calib \
            usr/share/skylit/presets.yaml usr/share/skylit/shaders/visibility.frag \
            usr/share/skylit/examples/config/sample_site.yaml usr/share/skylit/examples/data/models/gate.glb \
            usr/lib/systemd/system/skylit-live.service usr/lib/systemd/system/skylit-sky-node.service \
            usr/share/doc/skylit/copyright usr/share/doc/skylit/changelog.gz usr/share/man/man1/skylit-live.1.gz; do
  [[ -e "$root/$file" ]] || fail "the package lacks /$file"
done
# Nothing the programs look up at run time points into the source or build tree.
for program in "$root"/usr/bin/*; do
  if strings "$program" | grep -E "^($source|$build)/(shaders|config|share)" > "$work/paths"; then
    fail "$(basename "$program") names $(head -1 "$work/paths"): a path of the tree it was built in"
  fi
done

# The examples, copied out of the package as docs/install.md says, run by the unpacked programs.
bin="$root/usr/bin"
site="$work/site"
cp -r "$root/usr/share/skylit/examples" "$site"
cd "$site"
demo=build/demo
# The presets are the installed ones (the default of --presets, shown by --help). The help is
# read whole first: grep -q leaves at its first match, and with pipefail a program still
# writing into the closed pipe would fail the check.
bake_help=$("$bin/skylit-bake" --help)
grep -q -- "--presets TEXT=$root/usr/share/skylit/presets.yaml" <<<"$bake_help" ||
  fail "skylit-bake's presets are not the unpacked ones: $(grep -- --presets <<<"$bake_help")"
"$bin/skylit-bake" config/sample_site.yaml -o $demo/bake --quiet
"$bin/skylit-bake" verify $demo/bake > "$work/verify.log"
"$bin/skylit-sky" --calib config/sky_camera.yaml --equirect data/hdri/park.exr -o $demo/sky/park.exr --quiet
"$bin/skylit-shade" --bake $demo/bake --sky $demo/sky/park.exr --sky-calib config/sky_camera.yaml -o $demo/shade --quiet
[[ -f $demo/shade/sky.json ]] || fail "skylit-shade wrote no sky.json"
# Twice the frames the service is asked for: on a loaded machine it may drop a few (the demo's
# camera is paced, and a frame the renderer had no time for is dropped, not queued).
"$bin/skylit-camera-sim" --calib config/hmd_camera.yaml -o $demo/camera --frames 60 --sweep 10 --quiet
"$bin/skylit-live" config/demo.yaml --headless --frames 30 --status 127.0.0.1:0 --record $demo/frames --quiet
frames=$(find $demo/frames -name 'frame_*.png' | wc -l)
[[ $frames -eq 30 ]] || fail "skylit-live recorded $frames frames, not 30"
say "the unpacked programs baked, verified, shaded and composited 30 frames of the examples"

# The units, against the unpacked programs (systemd's own units copied beside them).
mkdir -p "$root/etc/systemd/system"
cp -r /lib/systemd/system/. "$root/usr/lib/systemd/system/"
for unit in skylit-live.service skylit-sky-node.service; do
  grep -q "^ExecStart=/usr/bin/" "$root/usr/lib/systemd/system/$unit" || fail "$unit does not start /usr/bin's program"
  if output=$(systemd-analyze verify --man=no --root="$root" "/usr/lib/systemd/system/$unit" 2>&1) && [ -z "$output" ]; then
    say "$unit passes systemd-analyze verify"
  else
    fail "$unit fails systemd-analyze verify: $output"
  fi
done
