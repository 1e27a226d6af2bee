#!/usr/bin/env bash
# Installs the system libraries Lantern needs when they are missing:
# Mesa's EGL and llvmpipe for the engine's headless context, and the shared
# libraries that Blender-as-a-module (bpy) links against, and chromium for the
# browser test of the compare report.
set -euo pipefail
need=()
have() { ldconfig -p | grep -q "$1"; }
have 'libEGL.so.1'        || need+=(libegl1)
have 'libEGL_mesa.so.0'   || need+=(libegl-mesa0)
ls /usr/lib/*/dri/swrast_dri.so >/dev/null 2>&1 || need+=(libgl1-mesa-dri)
have 'libGL.so.1'         || need+=(libgl1)
have 'libvulkan.so.1'     || need+=(libvulkan1)
have 'libX11.so.6'        || need+=(libx11-6)
have 'libXrender.so.1'    || need+=(libxrender1)
have 'libXfixes.so.3'     || need+=(libxfixes3)
have 'libXi.so.6'         || need+=(libxi6)
have 'libxkbcommon.so.0'  || need+=(libxkbcommon0)
have 'libSM.so.6'         || need+=(libsm6)
# Debian's chromium: the headless browser that opens `lantern compare`'s report in tests.
command -v chromium >/dev/null 2>&1 || need+=(chromium)
if [ ${#need[@]} -gt 0 ]; then
  echo "installing system packages: ${need[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need[@]}"
fi
