"""Derive the ``op3`` robot profile from the OP3's MuJoCo model (footstep_gym/fullbody/profile.py).

    python baselines/op3_profile.py            # print configs/robots/op3.yaml as the model gives it
    python baselines/op3_profile.py --write    # write it (tests/test_fullbody.py compares the two)
"""

from __future__ import annotations

import argparse
import sys

from footstep_gym.config import config_dir
from footstep_gym.fullbody.profile import profile_yaml


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write configs/robots/op3.yaml")
    args = parser.parse_args(argv)
    text = profile_yaml()
    if not args.write:
        sys.stdout.write(text)
        return 0
    path = config_dir() / "robots" / "op3.yaml"
    path.write_text(text, encoding="utf-8")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
