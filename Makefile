# Every target that needs the environment builds .venv itself: a fresh clone needs nothing else.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
STAMP := $(VENV)/.installed
HARMONY := $(VENV)/bin/harmony
TABLE1 := scenarios/paper/table1_s_shape.yaml
# results copied with their provenance entries (make lint checks every committed result's)
COPY := $(VENV)/bin/python tools/copy_results.py

.PHONY: install quickstart lint test test-slow bench reproduce-paper engines robots-unedited study study-validation claims results docs clean

# Ranges live in pyproject.toml; constraints.txt pins the versions every install uses (refresh it with
# `.venv/bin/pip freeze | grep -v '^-e' > constraints.txt` after a deliberate upgrade).
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "harmony needs Python 3.11 (PyBullet wheels)"'
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install -q --upgrade pip
	$(VENV)/bin/pip install -q -c constraints.txt -e '.[test,dev,robots,study,ray,view,docs]'
	touch $(STAMP)

install: $(STAMP)

# a newcomer's first minute: the paper's box carry, closed loop in PyBullet, into results/runs/pick_and_carry-<time>/
quickstart: $(STAMP)
	$(HARMONY) run scenarios/paper/pick_and_carry.yaml

# ruff (lint + format), mypy, import contracts (import-linter), module/function/README sizes, docs tables in sync,
# docs that read as results not a diary (tools/check_docs.py), committed results made by the code as it is
# (tools/check_results.py), the docs site (mkdocs.yml) with every link resolved
lint: $(STAMP)
	$(VENV)/bin/ruff check harmony_cli tests tools
	$(VENV)/bin/ruff format --check harmony_cli tests tools
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports --no-cache
	$(VENV)/bin/python tools/check_sizes.py harmony_cli
	$(VENV)/bin/python tools/render_docs.py --check
	$(VENV)/bin/python tools/check_docs.py
	$(VENV)/bin/python tools/check_results.py
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --quiet

# the tables in docs/*.md from the committed result files
docs: $(STAMP)
	$(VENV)/bin/python tools/render_docs.py

test: $(STAMP)
	$(VENV)/bin/pytest -q

test-slow: $(STAMP)
	$(VENV)/bin/pytest -q -m slow

# the paper's claims over distributions and under imperfections (studies/claims_*.yaml, their validation draws);
# CLAIMS_ON="--ray auto" runs them on a Ray cluster. Every study target resumes: started again after a stop, it runs
# what is missing and what the stop interrupted (RESUME)
RESUME := --rerun interrupted
CLAIMS := claims_table1 claims_admittance claims_moving_obstacle claims_sensing
CLAIMS_ON ?= --jobs 2
claims: $(STAMP)
	for s in $(CLAIMS); do \
		$(HARMONY) study studies/$$s.yaml --draws validation $(CLAIMS_ON) $(RESUME) --out results/claims/$$s || exit 1; done
	$(VENV)/bin/python tools/claims_table.py results/claims/claims.md $(addprefix results/claims/,$(CLAIMS))

bench: $(STAMP)
	$(HARMONY) bench --scenario $(TABLE1) --out results/bench/bench.json --engine pybullet --engine mujoco

EXPERIMENTS := pick_and_carry static_obstacles narrow_passage dynamic_obstacle
ROBOTS := pr2 tiago_dual baxter
comma := ,
space := $(subst ,, )

# Table 1 (IPOPT to convergence) + the extended table with real-time iteration, one run at a time; then the
# two-stage experiments (each with a video) and their results table; dynamic_obstacle again with the obstacle
# parked (static), the two side by side (dynamic_obstacle.md) and their paths overlaid; the catalogue robots'
# S-shape (robots_s_shape.md) and box carry (one row each in the experiments table, same scene file for all);
# the push-recovery ablation (admittance on / off) and its push plots.
reproduce-paper: $(STAMP)
	$(HARMONY) compare $(TABLE1) --grid solver.name=ipopt,rti --grid mpc.transcription=traditional,bezier \
		--grid mpc.knots=6,26 --jobs 1 --out results/paper --name table1 --main-solver ipopt
	for e in $(EXPERIMENTS); do \
		$(HARMONY) run scenarios/paper/$$e.yaml --out results/paper/runs/$$e --video || exit 1; done
	$(HARMONY) run scenarios/paper/dynamic_obstacle.yaml --set world.obstacles.1.motion=null \
		--set name=dynamic_obstacle_static --out results/paper/runs/dynamic_obstacle_static
	$(HARMONY) compare scenarios/robots/s_shape.yaml --grid robot.preset=$(subst $(space),$(comma),$(ROBOTS)) \
		--jobs 1 --out results/paper/robots --name robots_s_shape
	$(COPY) results/paper/robots/robots_s_shape.md results/paper/robots/robots_s_shape.csv results/paper/
	for r in $(ROBOTS); do $(HARMONY) run scenarios/robots/box_carry.yaml --set robot.preset=$$r \
		--set name=$${r}_box_carry --out results/paper/runs/$${r}_box_carry --video || exit 1; done
	$(HARMONY) experiments $(addprefix results/paper/runs/,$(EXPERIMENTS) $(addsuffix _box_carry,$(ROBOTS))) \
		--out results/paper
	$(HARMONY) experiments $(addprefix results/paper/runs/,dynamic_obstacle dynamic_obstacle_static) \
		--out results/paper --name dynamic_obstacle
	$(HARMONY) paths $(addprefix results/paper/runs/,dynamic_obstacle dynamic_obstacle_static) \
		--out results/paper/dynamic_obstacle_paths.png
	$(COPY) results/paper/runs/pick_and_carry/force_tracking.png results/paper/pick_and_carry_force.png
	$(HARMONY) compare scenarios/paper/push_recovery.yaml --grid admittance.enabled=true,false --jobs 1 \
		--out results/paper/push_recovery --name push_recovery
	$(COPY) results/paper/push_recovery/push_recovery.md results/paper/push_recovery/push_recovery.csv results/paper/
	for a in true false; do $(COPY) results/paper/push_recovery/runs/enabled-$$a/push_left_hand.png \
		results/paper/push_recovery_admittance_$$a.png; done
	$(VENV)/bin/python tools/render_docs.py

# the paper's two-stage experiments, Table 1's S and the catalogue robots' box carry in both physics engines, one
# run at a time; results/engines/engines.md sets their outcomes side by side
ENGINES := pybullet mujoco
engines: $(STAMP)
	for g in $(ENGINES); do \
		for e in $(EXPERIMENTS) table1_s_shape; do $(HARMONY) run scenarios/paper/$$e.yaml --set sim.engine=$$g \
			--set name=$$e --out results/engines/runs/$$g/$$e --quiet || true; done; \
		for r in $(ROBOTS); do $(HARMONY) run scenarios/robots/box_carry.yaml --set robot.preset=$$r \
			--set sim.engine=$$g --set name=$${r}_box_carry --out results/engines/runs/$$g/$${r}_box_carry --quiet \
			|| true; done; done
	$(VENV)/bin/python tools/engines_table.py results/engines/runs --out results/engines/engines.md

# the catalogue S for robots as example-robot-data ships them, each from a robot section of at most five lines and
# no preset (scenarios/robots/unedited/); a robot whose run fails is tabulated with its failure, not skipped
UNEDITED := pr2 tiago_dual baxter talos g1 centauro romeo icub
robots-unedited: $(STAMP)
	for r in $(UNEDITED); do $(HARMONY) run scenarios/robots/unedited/$$r.yaml \
		--out results/robots_unedited/runs/$$r --quiet; done; true
	$(HARMONY) experiments $(addprefix results/robots_unedited/runs/,$(UNEDITED)) --out results/robots_unedited \
		--name robots_unedited

# pick_and_carry over randomised scenes on 2 local jobs (resumable, RESUME above): `study`
# runs the 100 draws for development (dev) in PyBullet; `study-validation` the 200 that are run to report, never to
# choose between variants, in both physics engines side by side with the draws where they disagree (1.3-2.5 h); their
# reports, figures and study.parquet are committed under results/studies/ (the run directories are not)
study: $(STAMP)
	$(HARMONY) study studies/pick_and_carry_random.yaml --draws dev --jobs 2 $(RESUME)

study-validation: $(STAMP)
	$(HARMONY) study studies/pick_and_carry_random.yaml --draws validation --grid sim.engine=pybullet,mujoco --jobs 2 $(RESUME)

# every committed result made again by the code as it is (what tools/check_results.py asks for after a change to the
# source a run executes), one target after another on this machine, then the docs' tables; the study targets resume
# where a stop left them, so `make results` started again after a stop goes on from there
results: reproduce-paper engines robots-unedited bench study study-validation claims
	$(MAKE) docs

clean:
	rm -rf results/runs results/compare results/bench results/robots_unedited/runs results/paper/runs results/paper/push_recovery results/paper/robots .pytest_cache .hypothesis
