#!/usr/bin/env bash
# The systemd units pass `systemd-analyze verify` as a source install puts them: the build is
# installed (DESTDIR=ROOT cmake --install, prefix /usr/local) into a throwaway root, systemd's own
# units are copied beside them, and each installed unit is verified there (its ExecStart, under
# /usr/local/bin, must exist and be executable; every directive known). The package's units are
# checked by check_package.sh. Registered as the CTest Systemd.Units.
#
#   bash tests/install/check_units.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
source=$(cd "$2" && pwd)
root=$(mktemp -d "${TMPDIR:-/tmp}/skylit_units_XXXXXX")
trap 'rm -rf "$root"' EXIT

DESTDIR="$root" cmake --install "$build" --prefix /usr/local > "$root/install.log"
units="$root/usr/local/lib/systemd/system"
mkdir -p "$root/usr/lib/systemd" "$root/etc/systemd/system"
cp -r /lib/systemd/system "$root/usr/lib/systemd/"
status=0
for unit in "$source"/config/*.service; do
  name=$(basename "$unit")
  [[ -f "$units/$name" ]] || { echo "check_units: $name was not installed into /usr/local/lib/systemd/system" >&2; status=1; continue; }
  grep -q "^ExecStart=/usr/local/bin/" "$units/$name" || { echo "check_units: $name does not start /usr/local/bin's program" >&2; status=1; }
  # A clean unit makes verify print nothing: a warning (an unknown key, which systemd ignores) fails too.
  if output=$(systemd-analyze verify --man=no --root="$root" "/usr/local/lib/systemd/system/$name" 2>&1) && [ -z "$output" ]; then
    echo "check_units: $name passes systemd-analyze verify"
  else
    echo "check_units: $name fails systemd-analyze verify:" >&2
    echo "$output" >&2
    status=1
  fi
done
exit $status
