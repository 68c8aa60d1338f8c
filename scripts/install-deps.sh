#!/bin/sh
# Installs PipeRun's build and test dependencies from Debian 12 packages.
# Does nothing (and needs no network) when everything is already installed.
set -eu

PACKAGES="
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libpcl-dev libvtk9-dev
  libglfw3-dev libosmesa6-dev libtbb-dev
  nlohmann-json3-dev libcli11-dev libpugixml-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  xvfb xdotool imagemagick x11-utils
  python3-ezdxf
"

missing=""
for package in $PACKAGES; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing="$missing $package"
  fi
done

if [ -z "$missing" ]; then
  exit 0
fi

echo "install-deps: installing:$missing" >&2
if [ "$(id -u)" -ne 0 ]; then
  SUDO=sudo
else
  SUDO=
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
# shellcheck disable=SC2086
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
