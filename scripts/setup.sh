#!/usr/bin/env bash
# Installs what `make report` and `make test` need on a fresh Debian machine, and skips
# whatever is already there: Debian packages (apt-get, as root), then .venv with the project.
set -euo pipefail
cd "$(dirname "$0")/.."

DEBIAN_PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libopenexr-dev libpng-dev zlib1g-dev nlohmann-json3-dev libgtest-dev
  libglfw3-dev libglm-dev libepoxy-dev libegl-dev libegl-mesa0 libgl1-mesa-dri libgles-dev
  xvfb xauth libllvm19 chromium poppler-utils bubblewrap
  clang libclang-rt-14-dev clang-format
  python3-venv libseccomp2
)

missing=()
for p in "${DEBIAN_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install -q --upgrade pip
echo "setup: installing rtval into .venv, editable (Python runs from the tree; builds demo_cpp)"
.venv/bin/python -m pip install -q -e ".[test]"
