"""Derive the ``op3`` robot profiles from the OP3's MuJoCo model (footstep_gym/fullbody/profile.py).

    python baselines/op3_profile.py            # print configs/robots/op3.yaml and op3-lipm.yaml as the model gives them
    python baselines/op3_profile.py --write    # write them (tests/test_fullbody.py compares)
"""

from __future__ import annotations

import argparse
import sys

from footstep_gym.config import config_dir
from footstep_gym.fullbody.profile import PROFILES, derive_profile, profile_yaml


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write configs/robots/op3.yaml and op3-lipm.yaml")
    args = parser.parse_args(argv)
    derived = derive_profile()
    for name in PROFILES:
        text = profile_yaml(derived, name)
        if not args.write:
            sys.stdout.write(text + "\n")
            continue
        path = config_dir() / "robots" / f"{name}.yaml"
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
