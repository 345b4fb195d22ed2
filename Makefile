# horizon — the two commands a user needs:
#   make demo   installs missing Debian packages, builds, renders the default
#               generated 4097x4097 terrain headless with every effect on (a lake
#               shore against the sun) to out/demo.png, prints its figures
#   make test   installs, builds and runs every test (ctest)
#   make bench  the standard benchmark set -> out/bench/*.json, out/bench/summary.md
BUILD ?= build
JOBS  ?= 2
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release
ifeq ($(CI),true)
CMAKE_FLAGS += -DHZ_WERROR=ON
endif
HORIZON = $(BUILD)/apps/horizon/horizon

.PHONY: all deps build demo test bench clean

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

test: build
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

bench: build
	@bash scripts/deps.sh bench
	bash bench/standard.sh $(HORIZON) ../shared/data

clean:
	rm -rf $(BUILD) out
