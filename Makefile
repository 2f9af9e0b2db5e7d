# IRS workspace: `make demo` sets everything up and runs the main demo, `make test` runs the tests.
# Set-up is incremental: the venv is rebuilt only when env/requirements.txt changes, the colcon
# workspace only when a package file changes.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
UV := $(VENV)/bin/uv
ENV_STAMP := $(VENV)/.irs-requirements.stamp
LOCK := env/requirements.lock
BUILD_STAMP := install/.irs-build.stamp
PACKAGES := irs_msgs irs_common irs_models irs_sensing irs_treadmill irs_vehicle_sim irs_control irs_hardware irs_bag irs_bringup irs_sysid irs_studies irs_system_tests
# The files whose change needs colcon again. Python modules are not among them: the ament_python
# packages are installed with --symlink-install (develop mode), so edits to them are live.
PACKAGE_FILES := $(shell find $(PACKAGES) -type f \( -name package.xml -o -name 'setup.*' \
  -o -name CMakeLists.txt -o -name '*.cmake' -o -path '*/msg/*' -o -path '*/resource/*' \
  -o -path '*/config/*' \) 2>/dev/null)

.PHONY: demo test figures env build native clean help lock

help:
	@echo "make demo   set up (venv + colcon build) and run the Figure 10 demo"
	@echo "make test   set up and run the whole test suite"
	@echo "make figures  reproduce the paper's Figures 5-10 into docs/img (ONLY='treadmill actuator' for some parts)"
	@echo "make build  set up only (venv, colcon, the compiled cores);  make clean  remove venv and build products"
	@echo "make lock   re-resolve env/requirements.txt into the pinned env/requirements.lock"

env: $(ENV_STAMP)
build: native

# The venv installs the full pinned set in $(LOCK) (every transitive dependency), which
# `make lock` resolves from the direct requirements in env/requirements.txt.
$(ENV_STAMP): $(LOCK) env/venv_local_setup.sh.in
	@command -v $(PYTHON) >/dev/null || { echo "error: $(PYTHON) not found (Python 3.11 is needed)"; exit 1; }
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' || \
	  { echo "error: the ros-jazzy wheels need Python 3.11; set PYTHON=python3.11"; exit 1; }
	@test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV) || \
	  { echo "error: '$(PYTHON) -m venv' failed; on Debian: apt-get install python3-venv python3-dev"; exit 1; }
	@test -x $(UV) || { $(VENV)/bin/python -m pip --version >/dev/null 2>&1 || $(VENV)/bin/python -m ensurepip --default-pip >/dev/null; \
	  $(VENV)/bin/python -m pip install --quiet --disable-pip-version-check uv==0.13.9; }
	$(UV) pip install --quiet --python $(VENV)/bin/python -r $(LOCK)
	@# Bytecode once, here: uv installs none, and where PYTHONDONTWRITEBYTECODE is set (this
	@# machine, many containers) every process would compile scipy, matplotlib, control, rclpy
	@# again at start: measured 5.2 s of CPU for their import, 1.7 s with bytecode.
	$(VENV)/bin/python -m compileall -q -j 0 $(VENV)/lib/python3.11/site-packages
	@sed -e 's|@VENV@|$(CURDIR)/$(VENV)|' -e 's|@ROOT@|$(CURDIR)|' env/venv_local_setup.sh.in \
	  > $(VENV)/local_setup.sh
	@printf '. "%s/local_setup.sh"\n' "$(CURDIR)/$(VENV)" > $(VENV)/local_setup.bash
	@touch $@

lock: $(ENV_STAMP)
	$(UV) pip compile --quiet --python-version 3.11 env/requirements.txt -o $(LOCK)

# colcon builds irs_msgs (ament_cmake, rosidl) and the ament_python packages into install/.
# AMENT_PREFIX_PATH/CMAKE_PREFIX_PATH point at the venv, which is a ROS install prefix.
# irs_msgs/cmake/wheel_prefix_fixes.cmake repairs include paths the wheels' CMake exports
# carry over from their build container (see the comment in that file).
$(BUILD_STAMP): $(ENV_STAMP) $(PACKAGE_FILES)
	@# --symlink-install leaves links to deleted sources in build/, which then fail the build.
	@test ! -d build || find build -xtype l -delete
	@source env/venv.bash && colcon --log-base build/log build --merge-install --symlink-install \
	  --base-paths $(PACKAGES) --event-handlers console_cohesion- status- \
	  --cmake-args -DPython3_EXECUTABLE=$$VIRTUAL_ENV/bin/python \
	    -DCMAKE_PROJECT_INCLUDE=$(CURDIR)/irs_msgs/cmake/wheel_prefix_fixes.cmake \
	    -DBUILD_TESTING=OFF
	@# Our own bytecode too (see the env step; 0.1-0.2 s of CPU per node start). An edited
	@# module's stale .pyc is ignored: Python compiles the source instead, as without one.
	$(VENV)/bin/python -m compileall -q -j 0 install/lib/python3.11/site-packages \
	  $(foreach p,$(filter-out irs_msgs,$(PACKAGES)),$(p)/$(p))
	@touch $@

# mypyc compiles the offline loop's cores into build/native (irs_common.native_cores, about 18 s
# on two cores); every process of the workspace then imports them compiled. The script does
# nothing when the build matches the sources; when it cannot compile it says why in one line
# and the cores stay interpreted. IRS_PURE_PYTHON=1 runs the interpreted cores regardless.
native: $(BUILD_STAMP)
	@$(VENV)/bin/python env/build_native.py

demo: native
	./irs run irs_studies figure10

# Two pytest-xdist workers (each with its own ROS domain), a test module per worker at a time (its
# module fixtures run once); tests marked `exclusive` run alone (conftest.py). The 25 slowest
# tests are listed at the end (--durations).
TEST_WORKERS ?= 2
test: native
	./irs exec python -m pytest -n $(TEST_WORKERS) --dist loadscope --durations=25

# The paper's Figures 5-10 through the graph: experiments, identification, PNGs in docs/img.
# ONLY='treadmill vehicle' runs those parts only (make reads --options itself: hence a variable).
ONLY ?=
figures: native
	./irs run irs_studies figures --img-dir docs/img $(if $(strip $(ONLY)),--only $(ONLY))

clean:
	rm -rf $(VENV) build install log
