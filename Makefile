# Every target creates .venv if needed and installs what it uses: a fresh machine with
# Python >= 3.11 needs nothing else.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
OUT    ?= out

.PHONY: demo rig test bench bench-quality bench-heldout bench-camera bench-real bench-real-jpeg bench-approach bench-speed bench-ptu bench-survey bench-bus bench-field bench-record bench-edges bench-console bench-operator bench-security bench-printed bench-novelty bench-targets bench-sizes bench-aims bench-archive bench-nodata bench-mosaic bench-chips bench-stages bench-ab lint clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(PY) -m cyborg.clients demo --out $(OUT)/demo

# A simulated rig on 127.0.0.1:7447 to try the clients with (Ctrl-C stops it):
# `.venv/bin/cyborg keypad`, `.venv/bin/cyborg operator`, `.venv/bin/cyborg status`.
rig: $(STAMP)
	$(PY) -m cyborg.daemon run --sim

test: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m pytest -q

bench: bench-quality bench-heldout bench-camera bench-real bench-real-jpeg bench-approach bench-speed bench-ptu bench-survey bench-bus bench-field bench-record bench-edges bench-console bench-operator bench-security bench-printed bench-novelty bench-targets bench-sizes bench-aims bench-archive bench-nodata bench-mosaic bench-chips

bench-quality: $(STAMP)
	$(PY) -m bench.quality --scenes 120

# The same regimes drawn by an independent generator (bench/heldout.py), never tuned on.
bench-heldout: $(STAMP)
	$(PY) -m bench.quality --scenes 120 --heldout

# The same scenes as an ordinary camera delivers them (vignetting, gradient, defocus, JPEG),
# its frame the analysed size, then twice it (as the rig's mosaics are).
bench-camera: $(STAMP)
	$(PY) -m bench.quality --scenes 120 --camera
	$(PY) -m bench.quality --scenes 120 --camera --camera-scale 2

# Real labelled images from ../shared/data/real (or env CYBORG_REAL_DATA); says so if absent.
bench-real: $(STAMP)
	$(PY) -m bench.real

# The same, each repeat look saved as a camera's JPEG (quality 75) after its sensor noise.
bench-real-jpeg: $(STAMP)
	$(PY) -m bench.real --jpeg 75

# 30 simulated 300 -> 60 -> 10 m approaches on procedural worlds, memory on and off.
bench-approach: $(STAMP)
	$(PY) -m bench.approach --approaches 30

bench-speed: $(STAMP)
	$(PY) -m bench.speed

bench-ptu: $(STAMP)
	$(PY) -m bench.ptu

bench-survey: $(STAMP)
	$(PY) -m bench.survey

bench-bus: $(STAMP)
	$(PY) -m bench.bus

# A frozen viewer, a cancel mid-analysis, an idle rig, a flood of huge requests.
bench-field: $(STAMP)
	$(PY) -m bench.field

# The session log after a SIGKILL mid-station: what the ordinary mcap reader opens.
bench-record: $(STAMP)
	$(PY) -m bench.record

# Scripts at the edges: a vanished rig, Ctrl-C, a closed pipe.
# Aims of study on mixed scenes (a stain, a vein, a plant and a lichen in each view; a pale
# cliff and grey rock, some with sky): the requested kind first, the excluded ones last.
bench-aims: $(STAMP)
	$(PY) -m bench.aims --scenes 15

# cyborgd analyze over 200 real images: the last sequential release's command vs one process per core.
bench-archive: $(STAMP)
	$(PY) -m bench.archive --images 200

# The real images framed as mosaic tiles and turned panoramas with a black no-data fill.
bench-nodata: $(STAMP)
	$(PY) -m bench.nodata

# Butted vs pose-only vs registered mosaics from a head and camera with their flaws on (issue 45).
bench-mosaic: $(STAMP)
	$(PY) -m bench.mosaic --scenes 60

# Chips re-pointed at their targets with a 0.3 deg pointing error on, with and without refinement.
bench-chips: $(STAMP)
	$(PY) -m bench.chips --stations 20

# CPU ms per stage of `default` on real images and the seed's 108x192 mosaic (where the time goes).
bench-stages: $(STAMP)
	$(PY) -m bench.stages

# Paired CPU-time A/B against another tree with its own venv: make bench-ab BEFORE=../old-tree
bench-ab: $(STAMP)
	$(PY) -m bench.ab --before $(BEFORE)

bench-edges: $(STAMP)
	$(PY) -m bench.edges

# The console under 400 slow-header connections at a 256-file limit.
bench-console: $(STAMP)
	$(PY) -m bench.console

bench-printed: $(STAMP)
	$(PY) -m bench.printed

bench-novelty: $(STAMP)
	$(PY) -m bench.novelty

# Does "no further target" ever hide a real target? Generated, strip and real views.
bench-targets: $(STAMP)
	$(PY) -m bench.targets --scenes 40 --sweep

# Target sizes said vs planted at 300, 60 and 10 m on 5 procedural worlds.
bench-sizes: $(STAMP)
	$(PY) -m bench.sizes --worlds 5

# Needs headless Chromium: Debian's chromium and chromium-driver.
bench-operator: $(STAMP)
	$(PY) -m bench.operator

# Hostile queries, strangers and cross-origin console requests against a TLS rig; TLS cost.
bench-security: $(STAMP)
	$(PY) -m bench.security

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .

# Keeps $(OUT)/rig: `make rig`'s archive is field data, not a build product.
clean:
	rm -rf $(VENV) $(OUT)/demo .pytest_cache .ruff_cache *.egg-info
