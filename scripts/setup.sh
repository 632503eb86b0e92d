#!/usr/bin/env bash
# Installs the Debian 12 packages socketsmith needs to build and test, when they are missing.
# Idempotent: does nothing when everything is present. Runs apt-get as root (or via sudo).
# `scripts/setup.sh --dev` also installs ccache (scripts/build.sh then uses it: rebuilds and builds
# of other clones or worktrees under the same ccache base_dir take minutes instead of ~20) and
# clang with libclang-rt-14-dev (libFuzzer, ASan, UBSan) for scripts/fuzz.sh; `--slurm` installs
# Slurm and munge for the single-node cluster of scripts/slurm_local.sh.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libeigen3-dev           # dense/sparse linear algebra, CG
  libsuitesparse-dev      # CHOLMOD sparse Cholesky (static solver)
  libopenblas-dev         # optimised BLAS for CHOLMOD (the reference BLAS is ~5x slower)
  libcgal-dev             # AABB trees (closest point, ray casts) for meshing and contact
  libnlopt-cxx-dev        # derivative-free optimisation (constant calibration)
  calculix-ccx            # ccx, the independent FE solver of `socketsmith validate` (tests labelled validation)
  libcli11-dev            # command line
  nlohmann-json3-dev      # JSON (case files, --json output)
  libspdlog-dev libfmt-dev  # logging sink, formatting
  libstb-dev              # PNG writing
  libgtest-dev libgmock-dev  # tests
  libxml2-utils           # xmllint: the tests check the VTK and SVG files are well-formed XML (required in CI)
  libbenchmark-dev        # benchmarks
  libopencv-dev           # scan: 16-bit depth PNG IO, undistortion, Kinect calibration YAML (cv::FileStorage)
  libimgui-dev libglfw3-dev libgl-dev  # socketsmith-gui: Dear ImGui (with its GLFW/OpenGL3 back-ends), window, OpenGL
  fonts-dejavu-core  # socketsmith-gui's font: DejaVu Sans draws the report's μ, σ, →, ≤ (ImGui's own: Latin-1)
  xvfb xauth libgl1-mesa-dri  # GUI tests and screenshots headless: virtual X server, Mesa llvmpipe OpenGL
  chromium                # the reports' browser test: headless Chromium renders report.html and prints it to PDF
  pybind11-dev python3-pybind11 python3-dev  # the Python package socketsmith (docs/python.md), built for /usr/bin/python3
  python3-numpy python3-pytest  # its arrays and its tests (tests/python); the sweep test (tests/cli/sweep_test.py)
)

# --dev: ccache, and clang with its sanitizer/libFuzzer runtime for scripts/fuzz.sh.
# --slurm: Slurm and munge for scripts/slurm_local.sh (the slow test cli.sweep_slurm, docs/sweep.md).
for arg in "$@"; do
  case "$arg" in
    --dev) packages+=(ccache clang libclang-rt-14-dev) ;;
    --slurm) packages+=(slurmctld slurmd slurm-client munge) ;;
    *) echo "setup: unknown option '$arg' (--dev, --slurm)" >&2; exit 1 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} build packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
