#!/usr/bin/env bash
# Installs the Debian 12 packages Squall needs that are missing (and only those).
# Stops with a message naming the package when something cannot be installed.
set -u
PKGS=(build-essential cmake pkg-config libyaml-dev libpng-dev libepoxy-dev libegl-dev
      libgl1-mesa-dri libegl-mesa0 libavformat-dev libavcodec-dev libavutil-dev libswscale-dev
      libnetcdf-dev libomp-dev python3
      # WRF clouds (PROJ), real terrain (GDAL), meshes (assimp), the viewer (GTK 4 + Xvfb for its
      # tests), MPI scale-out (Open MPI, parallel NetCDF), fuzzing (clang + libFuzzer runtime),
      # independent readers used by the tests (ncdump, ncrcat, netCDF4-python, GDAL's Python,
      # VTK's Python)
      libproj-dev proj-data libgdal-dev gdal-bin libassimp-dev libgtk-4-dev xvfb xauth
      libopenmpi-dev openmpi-bin libnetcdf-mpi-dev clang libclang-rt-14-dev
      netcdf-bin nco python3-netcdf4 python3-numpy python3-gdal python3-vtk9 ffmpeg)
missing=()
for p in "${PKGS[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$p")
    fi
done
if [ ${#missing[@]} -eq 0 ]; then
    echo "deps: all ${#PKGS[@]} packages present"
    exit 0
fi
echo "deps: installing missing packages: ${missing[*]}"
SUDO=""
if [ "$(id -u)" != 0 ]; then
    if command -v sudo >/dev/null 2>&1; then SUDO=sudo; else
        echo "deps: missing packages ${missing[*]} and not root (no sudo): install them with apt-get" >&2
        exit 1
    fi
fi
export DEBIAN_FRONTEND=noninteractive
if ! $SUDO apt-get update -qq; then
    echo "deps: 'apt-get update' failed; cannot install ${missing[*]}" >&2
    exit 1
fi
for p in "${missing[@]}"; do
    if ! $SUDO apt-get install -y -qq --no-install-recommends "$p" >/tmp/squall-apt-$$.log 2>&1; then
        echo "deps: failed to install package '$p':" >&2
        tail -n 5 /tmp/squall-apt-$$.log >&2
        rm -f /tmp/squall-apt-$$.log
        exit 1
    fi
done
rm -f /tmp/squall-apt-$$.log
echo "deps: installed ${missing[*]}"
