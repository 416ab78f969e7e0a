# citylod — the two commands a new user needs are `make demo` and `make test`.
SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
CARGO ?= cargo
BIN := target/release/citylod
DEMO_IN := examples/nyc-les/les_buildings.geojson
DEMO_OUT := demo-out/nyc-les
SHARED := ../shared/data

.PHONY: all setup build demo test test-rust test-browser soak bench fmt lint clean

all: build

## Installs what the tests and the demo need (apt packages as root, npm ci); idempotent.
setup:
	@bash scripts/setup.sh

## Release build of the citylod binary.
build:
	$(CARGO) build --release --locked -p citylod

## Builds a tileset of the bundled Lower East Side data, screenshots it in CesiumJS and checks its cuts.
demo: setup build
	$(BIN) build $(DEMO_IN) --out $(DEMO_OUT)
	$(BIN) inspect $(DEMO_OUT)
	node tools/screenshot.mjs --tileset $(DEMO_OUT) --out $(DEMO_OUT)-cesium.png --view mid
	NODEVICE_SELECT=1 $(BIN) check $(DEMO_OUT) --out $(DEMO_OUT)-check
	@echo
	@echo "Tileset:     $(DEMO_OUT)/tileset.json   (build report: $(DEMO_OUT)/build-report.json)"
	@echo "Screenshot:  $(DEMO_OUT)-cesium.png"
	@echo "Check:       $(DEMO_OUT)-check/views.png  (cut, full detail and difference per view; report.json)"
	@echo "Look around: node tools/serve.mjs --root $(DEMO_OUT)   then open the printed viewer address"

## Every test: Rust unit, property, integration and end-to-end tests, glTF-Validator, and the two browser clients.
test: setup test-rust test-browser

# Property tests draw their cases from a fixed seed, so a run is repeatable and CI's verdict is the code's, not the
# dice's; `make soak` draws fresh ones. Set PROPTEST_RNG_SEED to replay another run's cases.
PROPTEST_RNG_SEED ?= 20261129
test-rust: export PROPTEST_RNG_SEED := $(PROPTEST_RNG_SEED)
test-rust:
	@if $(CARGO) nextest --version >/dev/null 2>&1; then \
		$(CARGO) nextest run --workspace --locked --no-fail-fast; \
	else \
		$(CARGO) test --workspace --locked --no-fail-fast; \
	fi
	$(CARGO) test --workspace --locked --doc

## Property tests with fresh random cases: SOAK_RUNS runs (default 20) of the crates' unit and generated tests, each
## run drawing a new seed, each case in a child process with a time limit (a case that hangs fails and is shrunk like
## any other). Failures are saved under each crate's proptest-regressions/, which `make test` replays first.
SOAK_RUNS ?= 20
soak:
	@for i in $$(seq $(SOAK_RUNS)); do \
		echo "soak run $$i of $(SOAK_RUNS)"; \
		env -u PROPTEST_RNG_SEED PROPTEST_FORK=true PROPTEST_TIMEOUT=60000 $(CARGO) test --release --locked --quiet \
			-p citylod-mesh -p citylod-generalize -p citylod-ingest --lib || exit 1; \
		env -u PROPTEST_RNG_SEED PROPTEST_FORK=true PROPTEST_TIMEOUT=60000 $(CARGO) test --release --locked --quiet \
			-p citylod-generalize --test generated || exit 1; \
	done

test-browser:
	node --test --test-concurrency=1 tests/browser/

## Timings and peak memory on real data (needs ../shared/data).
bench: build
	$(CARGO) build --release --locked -p citylod-bench
	target/release/citylod-bench --citylod $(BIN) --data $(SHARED)

fmt:
	$(CARGO) fmt --all

lint:
	$(CARGO) clippy --workspace --all-targets -- -D warnings

clean:
	rm -rf target demo-out node_modules
