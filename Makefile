# horizon — the two commands a user needs:
#   make demo   installs missing Debian packages, builds, renders the default
#               generated 4097x4097 terrain headless with every effect on (a lake
#               shore against the sun) to out/demo.png, prints its figures
#   make test   installs, builds and runs every test (ctest)
#   make bench  the standard benchmark set -> out/bench/*.json, out/bench/summary.md
#   make fuzz   every parser's libFuzzer target for FUZZ_SECONDS each (default 600)
# make test also builds build-san/ (clang, ASan + UBSan) and runs the unit
# tests there once more, and builds the fuzzers in build-fuzz/ (the same
# sanitizers plus libFuzzer's coverage instrumentation, which doubles the
# time of everything it is compiled into) and runs each for FUZZ_SHORT seconds.
BUILD ?= build
JOBS  ?= 2
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release
ifeq ($(CI),true)
CMAKE_FLAGS += -DHZ_WERROR=ON
endif
HORIZON = $(BUILD)/apps/horizon/horizon
# Sanitizer and fuzzer builds: clang, no -Werror (the gcc build is the warning
# gate; clang's extra warnings would fail CI on code gcc accepts). HZ_FUZZ is
# given either way, since a build folder keeps the cached value otherwise.
SAN_BUILD ?= build-san
SAN_FLAGS ?= -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHZ_SANITIZE=ON -DHZ_FUZZ=OFF
FUZZ_BUILD ?= build-fuzz
FUZZ_FLAGS ?= -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHZ_SANITIZE=ON -DHZ_FUZZ=ON -DHZ_BUILD_TESTS=OFF
FUZZ_SHORT ?= 20
FUZZ_SECONDS ?= 600

.PHONY: all deps build san fuzzers demo test test-san bench fuzz docs install clean

all: build

deps:
	@bash scripts/deps.sh

build: deps
	@cmake -S . -B $(BUILD) $(CMAKE_FLAGS) >/dev/null
	@cmake --build $(BUILD) -j$(JOBS)

demo: build
	@mkdir -p out
	$(HORIZON) render --generate perlin --size 4097 --seed 1 --effects all --sun 20,14 --time 20 \
	  --camera 13194,300,34469,-17,-4 --out out/demo.png

san: deps
	@CC=clang cmake -S . -B $(SAN_BUILD) $(SAN_FLAGS) >/dev/null
	@cmake --build $(SAN_BUILD) -j$(JOBS)

fuzzers: deps
	@CC=clang cmake -S . -B $(FUZZ_BUILD) $(FUZZ_FLAGS) >/dev/null
	@cmake --build $(FUZZ_BUILD) -j$(JOBS) --target fuzzers

test: build san fuzzers
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)
	@JOBS=$(JOBS) bash scripts/test-san.sh $(SAN_BUILD)
	@bash scripts/fuzz.sh $(FUZZ_BUILD) $(FUZZ_SHORT)

test-san: san
	@JOBS=$(JOBS) bash scripts/test-san.sh $(SAN_BUILD)

fuzz: fuzzers
	@bash scripts/fuzz.sh $(FUZZ_BUILD) $(FUZZ_SECONDS)

bench: build
	@bash scripts/deps.sh bench
	bash bench/standard.sh $(HORIZON) ../shared/data

# The API reference (Doxygen) from the public headers -> build/docs/html/index.html
docs:
	@bash scripts/deps.sh docs
	@mkdir -p build
	doxygen Doxyfile
	@echo "API reference: build/docs/html/index.html"

# libhorizon (static + shared), headers, horizon.pc and the CMake package into PREFIX
PREFIX ?= /usr/local
install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

clean:
	rm -rf $(BUILD) $(SAN_BUILD) $(FUZZ_BUILD) out
