"""The command lines of baselines/ loaded as modules, for tests of their argument parsing and main()."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

BASELINES = Path(__file__).resolve().parents[1] / "baselines"


def load_script(name: str) -> ModuleType:
    """``baselines/<name>.py`` as the module ``<name>_script``, loaded once per process."""
    module_name = f"{name}_script"
    if module_name not in sys.modules:
        spec = importlib.util.spec_from_file_location(module_name, BASELINES / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[module_name] = module  # its dataclasses look their module up
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[module_name]
            raise
    return sys.modules[module_name]
