# tendyn — set-up and checks. `make test` and `make demo` work on a fresh machine.
PY       ?= python3
VENV     := .venv
VPY      := $(VENV)/bin/python
PIP      := $(VPY) -m pip
STAMP    := $(VENV)/.tendyn-installed
DEPS     := $(VENV)/.tendyn-dependencies
BUILD_DEPS := scikit-build-core nanobind pin cmeel-eigen cmeel-urdfdom-headers
SOURCES  := $(shell find include src bindings python cmake -type f \( -name '*.hpp' -o -name '*.h' -o -name '*.cpp' -o -name '*.py' -o -name '*.toml' -o -name '*.in' -o -name '*.j2' \) 2>/dev/null) CMakeLists.txt pyproject.toml

.PHONY: install test test-steps test-python test-cpp cpp-build test-asan tools demo bench realdata scs126 mutants docs clean

# The venv's own pip (ensurepip: pip >= 21.2 on Python >= 3.10) builds tendyn; upgrading it first cost ~2 s of a
# fresh set-up and changed nothing it does here (issue 39).
$(VPY):
	$(PY) -m venv $(VENV)

# Build requirements go into the venv once, then the package builds without isolation (fast rebuilds). The
# dependencies (pyproject.toml's, the test extra's and the build requirements) go in through uv when it installs
# (~5 s against pip's ~55 s with the downloads cached; issue 39), else through pip; pip then builds and installs
# tendyn itself (it rebuilds a local folder every time, so a changed C++ source is never served from a cache).
# uv compiles the bytecode (pip does by default): where PYTHONDONTWRITEBYTECODE is set (it is on the machines
# this suite is timed on), every process would otherwise compile numpy, scipy, pandas and matplotlib from source
# at its start (5.4 s against 1.8 s for their import).
$(DEPS): $(VPY) pyproject.toml
	{ $(PIP) install -q uv && $(VENV)/bin/uv pip install -q --compile-bytecode --python $(VPY) $(BUILD_DEPS) \
	  -r pyproject.toml --extra test; } \
	  || $(PIP) install -q $(BUILD_DEPS)
	touch $(DEPS)

$(STAMP): $(DEPS) $(SOURCES)
	$(PIP) install -q --no-build-isolation ".[test]"
	touch $(STAMP)

install: $(STAMP)

# Workers of the Python suite: one per CPU this process may use (NPROC=1 runs it serially).
NPROC    ?= $(shell nproc 2>/dev/null || echo 2)
CTEST    := ctest --test-dir build/cpp --output-on-failure -j $(NPROC)
# Extra pytest options, e.g. PYTEST_ARGS="-p randomly" (shuffled order, its seed printed) or "-m slow".
PYTEST_ARGS ?=
# The Python suite on NPROC workers, each module whole on one worker, handed out in the collection order
# (conftest.py puts the heaviest modules first): pytest-xdist >= 3.5 otherwise hands out the modules with the most
# tests first, and the minute-long modules of few tests (the README walk-through) ran last (issue 39).
XDIST    := -n $(NPROC) --dist loadscope --no-loadscope-reorder

# The Python tests also build the C/C++ examples against the installed package (CMake, pkg-config, cc). The suite
# runs on every core (pytest-xdist; one module per worker at a time, so a module's fixtures are built once), prints
# its 15 slowest tests, and the whole of `make test` prints its wall time (docs/testing.md).
test:
	@start=$$(date +%s); $(MAKE) --no-print-directory test-steps; rc=$$?; \
	echo "[test] make test: $$(( $$(date +%s) - start )) s wall, $(NPROC) pytest workers, exit $$rc"; exit $$rc

# The package (its wheel: the Python module and the C ABI) and the C++ tests' build compile side by side: each
# alone leaves a core idle behind its longest translation unit. The wheel is the longer path (its Pinocchio
# unit the longest), so the C++ tests' build runs at a lower priority and takes the CPU the wheel leaves: both
# builds 194 s against 236 s at equal priority (docs/testing.md).
test-steps: tools
	@$(MAKE) --no-print-directory -j 2 install cpp-build
	$(CTEST)
	@start=$$(date +%s); TENDYN_REQUIRE_EXAMPLES=1 TENDYN_CPP_BUILD=$(abspath build/cpp) $(VPY) -m pytest tests/python -q $(XDIST) \
	  --durations=15 $(PYTEST_ARGS); rc=$$?; \
	echo "[test] Python suite: $$(( $$(date +%s) - start )) s wall"; exit $$rc

# pkg-config for tests/python/test_examples.py, headless chromium for tests/python/test_reports.py (the HTML
# reports opened in a browser); installed with apt when missing (root only).
tools:
	@command -v pkg-config >/dev/null || { [ "$$(id -u)" = 0 ] && { apt-get install -y -q pkg-config || \
	  { apt-get update -q && apt-get install -y -q pkg-config; }; } >/dev/null; } \
	  || echo "[tools] pkg-config is missing and cannot be installed without root: the pkg-config builds fail"
	@command -v chromium >/dev/null || { [ "$$(id -u)" = 0 ] && { apt-get install -y -q chromium || \
	  { apt-get update -q && apt-get install -y -q chromium; }; } >/dev/null; } \
	  || echo "[tools] chromium is missing and cannot be installed without root: the report browser tests skip"

test-python: install
	$(VPY) -m pytest tests/python -q $(XDIST) $(PYTEST_ARGS)

# C++ test executables (no allocation in the real-time calls, C ABI), through CTest. Their build needs the
# dependencies (Eigen, Pinocchio), not the package.
cpp-build: $(DEPS)
	mkdir -p build
	cmake -S . -B build/cpp -DTENDYN_BUILD_PYTHON=OFF -DTENDYN_BUILD_TESTS=ON -DCMAKE_INSTALL_LIBDIR=lib \
	      -DPython_EXECUTABLE=$(abspath $(VPY)) -DCMAKE_BUILD_TYPE=Release > build/cpp.log 2>&1 || (cat build/cpp.log; exit 1)
	nice -n 10 cmake --build build/cpp -j 2 >> build/cpp.log 2>&1 || (cat build/cpp.log; exit 1)

test-cpp: cpp-build
	$(CTEST)

# The C++ tests and the C loaders' fuzz under AddressSanitizer + UndefinedBehaviorSanitizer (leaks included):
# any finding fails the test (exit status). Not part of `make test`: the C ABI alone is ~3 min of CPU to build under
# the sanitizers, the Pinocchio tests far more (docs/c-package.md).
ASAN_ENV := ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1 \
            UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
test-asan: install
	mkdir -p build
	cmake -S . -B build/asan -DTENDYN_BUILD_PYTHON=OFF -DTENDYN_BUILD_TESTS=ON -DTENDYN_SANITIZE=ON \
	      -DPython_EXECUTABLE=$(abspath $(VPY)) -DCMAKE_BUILD_TYPE=RelWithDebInfo > build/asan.log 2>&1 || (cat build/asan.log; exit 1)
	cmake --build build/asan -j 2 >> build/asan.log 2>&1 || (cat build/asan.log; exit 1)
	$(ASAN_ENV) ctest --test-dir build/asan --output-on-failure

# Plant each bug of tests/mutants/mutants.toml in a scratch copy (/tmp), rebuild, run its tests, print the
# kill rate (~20 min on 2 cores). MUTANTS_ARGS="--tests-from main" measures another ref's tests.
mutants: install
	$(VPY) tests/mutants/run.py $(MUTANTS_ARGS)

# The documentation site (docs/*.md + the docstrings, mkdocs.yml) into build/site; warnings are errors.
docs: install
	$(VPY) -m mkdocs build --strict -f mkdocs.yml -d build/site

demo: install
	$(VENV)/bin/tendyn routing show lexos
	$(VENV)/bin/tendyn demo lexos --out out/demo/lexos
	$(VENV)/bin/tendyn demo mcgill_bench --out out/demo/mcgill_bench

bench: install
	$(PIP) install -q mujoco || echo "[bench] mujoco not installed: its entries are skipped"
	mkdir -p build
	cmake -S . -B build/bench -DTENDYN_BUILD_PYTHON=OFF -DTENDYN_BUILD_BENCHMARKS=ON \
	      -DPython_EXECUTABLE=$(abspath $(VPY)) -DCMAKE_BUILD_TYPE=Release > build/bench.log 2>&1 || (cat build/bench.log; exit 1)
	cmake --build build/bench -j 2 --target feedforward_timer compensator_timer routing_timer tendon_timer >> build/bench.log 2>&1 || (cat build/bench.log; exit 1)
	TENDYN_FEEDFORWARD_TIMER=$(abspath build/bench/benchmarks/feedforward_timer) \
	TENDYN_ROUTING_TIMER=$(abspath build/bench/benchmarks/routing_timer) \
	TENDYN_TENDON_TIMER=$(abspath build/bench/benchmarks/tendon_timer) \
	TENDYN_COMPENSATOR_TIMER=$(abspath build/bench/benchmarks/compensator_timer) $(VPY) benchmarks/run.py $(BENCH_ARGS)

# Every real data set of ../shared/external-data against its peers' published numbers (docs/realdata.md):
# benchmarks/realdata.json, the page in build/realdata/report.html and the table on stdout. The MTM row
# tendyn_preset_wpi_solver needs WPI's solver (SCS 1.2.6, `make scs126`, ~1 min; left empty without it).
realdata: install scs126
	$(VPY) benchmarks/realdata/run.py $(REALDATA_ARGS)

# SCS 1.2.6 (WPI's dVRK solver) from its source package in its own environment build/scs126/venv
# (needs libblas-dev and liblapack-dev); nothing of it enters tendyn's environment.
scs126:
	-bash benchmarks/realdata/build_scs126.sh

clean:
	rm -rf build $(VENV) out
