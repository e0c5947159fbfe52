# Every target that needs the environment builds .venv itself: a fresh clone needs nothing else.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
STAMP := $(VENV)/.installed
HARMONY := $(VENV)/bin/harmony
TABLE1 := scenarios/paper/table1_s_shape.yaml

.PHONY: install test test-slow bench reproduce-paper clean

$(STAMP): pyproject.toml
	$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "harmony needs Python 3.11 (PyBullet wheels)"'
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install -q --upgrade pip
	$(VENV)/bin/pip install -q -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

test: $(STAMP)
	$(VENV)/bin/pytest -q

test-slow: $(STAMP)
	$(VENV)/bin/pytest -q -m slow

bench: $(STAMP)
	$(HARMONY) bench --scenario $(TABLE1) --out results/bench/bench.json

EXPERIMENTS := pick_and_carry static_obstacles narrow_passage dynamic_obstacle

# Table 1 (IPOPT to convergence) + the extended table with real-time iteration, one run at a time; then the
# two-stage experiments (each with a video) and their results table; dynamic_obstacle again with the obstacle
# parked (static), the two side by side (dynamic_obstacle.md) and their paths overlaid.
reproduce-paper: $(STAMP)
	$(HARMONY) compare $(TABLE1) --grid solver.name=ipopt,rti --grid mpc.transcription=traditional,bezier \
		--grid mpc.knots=6,26 --jobs 1 --out results/paper --name table1 --main-solver ipopt
	for e in $(EXPERIMENTS); do \
		$(HARMONY) run scenarios/paper/$$e.yaml --out results/paper/runs/$$e --video || exit 1; done
	$(HARMONY) run scenarios/paper/dynamic_obstacle.yaml --set world.obstacles.1.motion=null \
		--set name=dynamic_obstacle_static --out results/paper/runs/dynamic_obstacle_static
	$(HARMONY) experiments $(addprefix results/paper/runs/,$(EXPERIMENTS)) --out results/paper
	$(HARMONY) experiments $(addprefix results/paper/runs/,dynamic_obstacle dynamic_obstacle_static) \
		--out results/paper --name dynamic_obstacle
	$(HARMONY) paths $(addprefix results/paper/runs/,dynamic_obstacle dynamic_obstacle_static) \
		--out results/paper/dynamic_obstacle_paths.png

clean:
	rm -rf results/runs results/compare results/bench results/paper/runs .pytest_cache .hypothesis
