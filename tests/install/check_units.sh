#!/usr/bin/env bash
# The systemd units in config/ pass `systemd-analyze verify` against the installed paths: the
# build is installed (cmake --install) into a throwaway root under /usr/local, systemd's own
# units are copied beside them, and every unit is verified there (its ExecStart must exist and
# be executable, every directive known). Registered as the CTest Systemd.Units.
#
#   bash tests/install/check_units.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
source=$(cd "$2" && pwd)
root=$(mktemp -d "${TMPDIR:-/tmp}/skylit_units_XXXXXX")
trap 'rm -rf "$root"' EXIT

cmake --install "$build" --prefix "$root/usr/local" > "$root/install.log"
mkdir -p "$root/usr/lib/systemd" "$root/etc/systemd/system"
cp -r /lib/systemd/system "$root/usr/lib/systemd/"
status=0
for unit in "$source"/config/*.service; do
  name=$(basename "$unit")
  cp "$unit" "$root/etc/systemd/system/$name"
  # A clean unit makes verify print nothing: a warning (an unknown key, which systemd ignores) fails too.
  if output=$(systemd-analyze verify --man=no --root="$root" "/etc/systemd/system/$name" 2>&1) && [ -z "$output" ]; then
    echo "check_units: $name passes systemd-analyze verify"
  else
    echo "check_units: $name fails systemd-analyze verify:" >&2
    echo "$output" >&2
    status=1
  fi
done
exit $status
