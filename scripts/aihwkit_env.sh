#!/usr/bin/env bash
# Build the virtual environment that runs IBM aihwkit 1.1.0 beside the project (the extra
# `aihwkit`): `bash scripts/aihwkit_env.sh`. Idempotent: an environment that already imports
# aihwkit with a tile that updates is kept, and the script returns in seconds.
#
# Where: $CML_EDGE_AIHWKIT_VENV, else ~/.cache/cml-edge/aihwkit-venv (outside the
# repository: one environment for every clone, kept between CI runs on a machine). The
# interpreter: $CML_EDGE_AIHWKIT_PYTHON (a Python 3.11), else python3.11 on PATH, else
# python3. `cml-edge device characterize --against aihwkit`, benchmarks/vs_aihwkit.py and
# the tests marked `aihwkit` find it at the same place (`--preset aihwkit:NAME` needs it only
# to write cml_edge/data/aihwkit_presets.json again).
#
# Why it is a second environment: aihwkit 1.1.0's compiled simulator runs only beside
# exactly torch 2.10.0 (2.9.1 fails at import, undefined c10::TensorImpl symbol; 2.13.0
# imports, but set_weights then rejects every shape), while the DQN extra uses torch 2.13.0.
# Its wheel is installed with --no-deps (its metadata asks for cmake, scikit-build, pybind11,
# mypy and torchvision, none used at run time). PyPI's torch 2.10.0 for Linux x86_64 is the
# CUDA build: it runs on the CPU, but its libraries link the CUDA runtime libraries at load
# time, so the NVIDIA wheels it loads are installed (with --no-deps: not cuda-bindings,
# nvtx, nvrtc, cusolver or triton, which a CPU import never loads). About 6 GB, 3 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${CML_EDGE_AIHWKIT_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/cml-edge/aihwkit-venv}"
python="${CML_EDGE_AIHWKIT_PYTHON:-$(command -v python3.11 || command -v python3)}"
check='import torch, aihwkit
from aihwkit.simulator.configs import SingleRPUConfig
from aihwkit.simulator.presets.devices import PCMPresetDevice
from aihwkit.simulator.tiles import AnalogTile
assert torch.__version__.split("+")[0] == "2.10.0" and aihwkit.__version__ == "1.1.0"
t = AnalogTile(4, 3, SingleRPUConfig(device=PCMPresetDevice()))
t.set_learning_rate(0.1)
t.set_weights(torch.full((4, 3), 0.5))
t.update(torch.ones(1, 3), -torch.ones(1, 4))
assert float(t.get_weights()[0].sum()) != 6.0'
if [ -x "$venv/bin/python" ] && "$venv/bin/python" -c "$check" 2>/dev/null; then
  echo "aihwkit environment ready: $venv/bin/python"
  exit 0
fi
if [ -e "$venv" ] && [ ! -f "$venv/pyvenv.cfg" ]; then
  echo "$venv exists and is not a virtual environment: left alone" >&2
  exit 1
fi
start=$(date +%s)
rm -rf "$venv"
mkdir -p "$(dirname "$venv")"
"$python" -m venv "$venv"
install() {  # pip install, without its notes on the requirements --no-deps leaves out
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "$@" 2>&1 |
    { grep -v -e "WARNING: Location" -e "which is not installed" -e "dependency resolver" \
        -e "dependency conflicts" || true; }
  return "${PIPESTATUS[0]}"
}
install --no-deps torch==2.10.0 aihwkit==1.1.0
install numpy scipy requests tqdm protobuf filelock 'typing-extensions>=4.10' \
  'sympy>=1.13.3' 'networkx>=2.5.1' jinja2 'fsspec>=0.8.5'
if [ "$(uname -m)" = x86_64 ]; then  # the CUDA libraries a CPU import of torch 2.10.0 loads
  install --no-deps nvidia-cuda-runtime-cu12==12.8.90 nvidia-cuda-cupti-cu12==12.8.90 \
    nvidia-cublas-cu12==12.8.4.1 nvidia-cudnn-cu12==9.10.2.21 nvidia-cufft-cu12==11.3.3.83 \
    nvidia-curand-cu12==10.3.9.90 nvidia-cusparse-cu12==12.5.8.93 \
    nvidia-cusparselt-cu12==0.7.1 nvidia-nccl-cu12==2.27.5 nvidia-nvshmem-cu12==3.4.5 \
    nvidia-cufile-cu12==1.13.1.3 nvidia-nvjitlink-cu12==12.8.93
fi
"$venv/bin/python" -c "$check"
echo "aihwkit environment built in $(( $(date +%s) - start )) s ($(du -sh "$venv" | cut -f1)):" \
  "$venv/bin/python"
