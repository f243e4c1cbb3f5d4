# Developer shortcuts. `make check` runs what CI runs (see .ci/run).
.PHONY: install test test-slow rust-test lint bench check

install:
	python3 -m pip install -e ".[dev,sim,perception,lerobot]" && python3 -m pip install --no-deps lerobot==0.4.4 robosuite==1.5.2

test:
	python3 -m pytest -q

test-slow:
	python3 -m pytest -q -m slow tests/cli tests/docs tests/e2e
	python3 -m pytest -q -m slow tests/unit

rust-test:
	cargo test --workspace

lint:
	cargo fmt --all --check
	cargo clippy --workspace --all-targets -- -D warnings
	python3 -m ruff check .
	python3 -m ruff format --check .
	python3 -m mypy python/lfd
	python3 -m mypy.stubtest lfd._hmmseg --allowlist .ci/stubtest-allowlist.txt

bench:
	python3 benches/engine_vs_hmmlearn.py
	python3 benches/dtw_vs_dtaidistance.py

check:
	bash .ci/run
