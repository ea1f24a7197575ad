#!/usr/bin/env bash
# A day with faults (scripts/soak.py has the schedule, the goals and the options):
#   scripts/soak.sh [--frames 1e6] [--fault-every 60] [--out build/soak] [--build build]
# Not part of `make test` (its short version is: CTest Soak.Faults). Needs the programs built.
exec /usr/bin/python3 "$(dirname "$0")/soak.py" "$@"
