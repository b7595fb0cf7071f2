"""Shared pytest setup: pygame must be able to open a (dummy) display on a headless machine."""

import os

# Before anything imports pygame: "human" rendering then works without a screen.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
