"""The package list, found rather than written by hand (everything else is in pyproject.toml): every package under
footstep_gym/, and footstep_gym.configs, which pyproject.toml maps to the top-level configs/ folder with its YAML
files as package data. A TOML file cannot say "found, plus one mapped folder"; this can."""

from setuptools import find_packages, setup

setup(packages=[*find_packages(include=["footstep_gym", "footstep_gym.*"]), "footstep_gym.configs"])
