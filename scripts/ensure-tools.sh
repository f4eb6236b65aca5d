#!/usr/bin/env bash
# Make sure the system tools the build needs are present.
#
# Usage: scripts/ensure-tools.sh COMMAND=DEBIAN_PACKAGE [...]
#
# Each argument names a command that must be on PATH, or an absolute path to a file that must exist
# (a header, for example), and the Debian package that provides it.
# As root, the missing packages are installed with apt-get (one `apt-get update` first).
# Otherwise nothing is changed: the script prints the exact apt-get line to run and fails.
set -euo pipefail

missing=()
for pair in "$@"; do
    command="${pair%%=*}"
    package="${pair#*=}"
    if [[ "$command" == /* ]]; then
        [ -e "$command" ] || missing+=("$package")
    elif ! command -v "$command" >/dev/null 2>&1; then
        missing+=("$package")
    fi
done
if ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then
    missing+=("python3-venv")
fi

[ ${#missing[@]} -eq 0 ] && exit 0

line="apt-get install -y --no-install-recommends ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
    echo "error: missing system packages: ${missing[*]}" >&2
    echo "run as root:  apt-get update && $line" >&2
    exit 1
fi
echo "installing system packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
$line
