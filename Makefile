# Quick start: `make run` opens the demo level (its scripted walk headless without a display);
# `make test` runs every test on a real Vulkan driver (Mesa's lavapipe is installed when no Vulkan
# driver is present) and Xvfb for the windowed test.

CARGO ?= cargo
SCENE ?= cornell
OUT ?= out/$(SCENE)
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# lavapipe's window-system code complains when this is unset, even headless.
export XDG_RUNTIME_DIR ?= /tmp/xdg-runtime-$(shell id -u)

.PHONY: run render test lint toolchain vulkan-driver xvfb bless fuzz soak peer peer-table

run: toolchain vulkan-driver
	@mkdir -p $(XDG_RUNTIME_DIR) && chmod 700 $(XDG_RUNTIME_DIR)
	@if [ -n "$$DISPLAY$$WAYLAND_DISPLAY" ]; then \
		$(CARGO) run --release -p game_demo -- play; \
	else \
		echo "no display (DISPLAY and WAYLAND_DISPLAY unset): the demo's scripted walk, headless"; \
		$(CARGO) run --release -p game_demo -- play --headless --frames 240 --every 30 --width 640 --height 360 --out out/play; \
	fi

# Renders one scene headless (SCENE=cornell by default).
render: toolchain vulkan-driver
	@mkdir -p $(XDG_RUNTIME_DIR) && chmod 700 $(XDG_RUNTIME_DIR)
	$(CARGO) run --release -p game_demo -- render --scene $(SCENE) --width 1280 --height 720 --out $(OUT)
	@echo "images: $(OUT)/image.png (tonemapped sRGB), $(OUT)/image.exr (linear radiance); GPU times: $(OUT)/timings.json"

test: toolchain vulkan-driver xvfb
	@mkdir -p $(XDG_RUNTIME_DIR) && chmod 700 $(XDG_RUNTIME_DIR)
	$(CARGO) test --workspace --no-fail-fast

# The full soak: 10,000 frames of the demo level headless, everything moving; fails if an image or
# atlas holds a NaN or Inf, memory grows or frame times drift beyond their bounds (out/soak/soak.csv).
SOAK_FRAMES ?= 10000
SOAK_ARGS ?= --width 320 --height 180 --probes 19,4,19 --rays 64
soak: toolchain vulkan-driver
	@mkdir -p $(XDG_RUNTIME_DIR) && chmod 700 $(XDG_RUNTIME_DIR)
	$(CARGO) run --release -p game_demo -- play --headless --soak --frames $(SOAK_FRAMES) $(SOAK_ARGS) --out out/soak

# Re-makes every reference image in tests/golden/ (testkit): the golden images from the current
# renderer, and the path-traced references from the path tracer at 4096 paths per pixel (minutes on
# a software driver).
bless: toolchain vulkan-driver xvfb
	@mkdir -p $(XDG_RUNTIME_DIR) && chmod 700 $(XDG_RUNTIME_DIR)
	BLESS=1 $(CARGO) test --workspace --no-fail-fast

# The peer benchmark against sgl-3d (peer/, outside the workspace: sgl-3d 0.5 declares Rust 1.96).
# By default a smoke run that fails when either renderer gives a non-finite or black image or never
# updates its probes; PEER_ARGS for a real one (docs/evaluation.md, "Peer benchmark").
PEER_ARGS ?= --scene cornell --width 64 --height 64 --frames 30 --skip 5 --reference-spp 64
peer: toolchain vulkan-driver
	@mkdir -p $(XDG_RUNTIME_DIR) && chmod 700 $(XDG_RUNTIME_DIR)
	$(CARGO) run --release --ignore-rust-version --manifest-path peer/Cargo.toml -- $(PEER_ARGS) --out out/peer --json out/peer/peer.json

# The peer table of BENCHMARKS.md in one command: cornell at 256×256, the cathedral and the demo
# level at 1280×720, 128 rays a probe, each scene's rows interleaved frame by frame; the three
# tables end up together in out/peer/table.md. Needs a GPU whose driver gives sgl-3d its binding tier.
# PEER_SHARES: the rows of ours capped at these shares of sgl-3d's rays (1: its count; 2: twice it,
# where the cathedral is ≥ 2× faster at lower FLIP and relative MSE).
PEER_SCENES ?= cornell:256:256 cathedral:1280:720 level:1280:720
PEER_SHARES ?= 1,2
peer-table: toolchain vulkan-driver
	@mkdir -p $(XDG_RUNTIME_DIR) && chmod 700 $(XDG_RUNTIME_DIR)
	@set -e; for s in $(PEER_SCENES); do \
		scene=$${s%%:*}; size=$${s#*:}; w=$${size%%:*}; h=$${size#*:}; \
		$(CARGO) run --release --ignore-rust-version --manifest-path peer/Cargo.toml -- --scene $$scene --width $$w --height $$h --rays 128 --ours-at-shares $(PEER_SHARES) --out out/peer --json out/peer/$$scene.json; \
	done; for s in $(PEER_SCENES); do cat out/peer/$${s%%:*}.md; echo; done > out/peer/table.md
	@echo "wrote out/peer/table.md"

# Fuzzes both scene importers for FUZZ_SECONDS each (cargo-fuzz, nightly; seeds in fuzz/corpus/).
# Crashes land in fuzz/artifacts/<target>/; turn each into a fixture and a test. Without a
# sanitizer (`-s none`): the importers are safe Rust, a crash is a panic, a hang or a runaway
# allocation, and the build is several times faster. FUZZ_SANITIZER=address for the full check.
FUZZ_SECONDS ?= 60
FUZZ_SANITIZER ?= none
fuzz:
	@command -v cargo-fuzz >/dev/null || $(CARGO) install cargo-fuzz
	$(CARGO) +nightly fuzz run -s $(FUZZ_SANITIZER) gltf -- -max_total_time=$(FUZZ_SECONDS) -rss_limit_mb=4096 -timeout=10
	$(CARGO) +nightly fuzz run -s $(FUZZ_SANITIZER) obj -- -max_total_time=$(FUZZ_SECONDS) -rss_limit_mb=4096 -timeout=10

lint: toolchain
	$(CARGO) fmt --all --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps -p engine -p ddgi -p ddgi_overlay -p pathtrace

# rust-toolchain.toml pins the toolchain; rustup installs it when it can download. A machine that
# cannot, whose `stable` toolchain is that same release, gets `stable` linked under the pinned name
# (a symbolic link in rustup's toolchains folder: `rustup toolchain link` refuses release names).
TOOLCHAIN := $(shell sed -n 's/^channel *= *"\(.*\)"/\1/p' rust-toolchain.toml)
toolchain:
	@if command -v rustup >/dev/null 2>&1 && ! rustup toolchain list | grep -q '^$(TOOLCHAIN)-' \
		&& rustc +stable -V 2>/dev/null | grep -q '^rustc $(TOOLCHAIN) '; then \
		host=$$(rustc +stable -vV | sed -n 's/^host: //p'); \
		echo "linking the stable toolchain ($(TOOLCHAIN)) as $(TOOLCHAIN)-$$host"; \
		ln -s "$$(rustc +stable --print sysroot)" "$${RUSTUP_HOME:-$$HOME/.rustup}/toolchains/$(TOOLCHAIN)-$$host"; \
	fi

# Installs Mesa's Vulkan drivers (lavapipe, a software rasterizer) and the Vulkan loader with apt,
# only when no Vulkan driver manifest or loader is present.
vulkan-driver:
	@if { ls /usr/share/vulkan/icd.d/*.json || ls /etc/vulkan/icd.d/*.json; } >/dev/null 2>&1 && ldconfig -p | grep -q 'libvulkan.so.1 '; then \
		: ; \
	else \
		echo "no Vulkan driver found: installing mesa-vulkan-drivers and libvulkan1"; \
		$(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq mesa-vulkan-drivers libvulkan1; \
	fi

# Installs Xvfb (the windowed demo's test runs under a virtual X server) when it is missing.
xvfb:
	@if command -v Xvfb >/dev/null 2>&1; then \
		: ; \
	else \
		echo "no Xvfb found: installing xvfb"; \
		$(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq xvfb libxkbcommon-x11-0 libxcursor1 libxrandr2 libxi6 libx11-xcb1; \
	fi
