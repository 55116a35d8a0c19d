"""The Foxglove layout shipped with dresslog: the counterpart of the Rerun blueprint.

`foxglove_layout.json` arranges a trial's standard channels (`dresslog.io.drawn`) as
the Rerun view does: the ground-truth heat map and the estimate side by side, each a 3D
panel colouring its cloud by `force` on one fixed scale (0-0.5 N, turbo) with the
garment and the gripper's path (the cloud draws the limb; the limb's sphere marker, whose
spheres would hide the cloud's dots, is off); under them the gripper's wrench, its twist, and the
total force on the limb (a user script in the layout sums each map). Import it in
Foxglove (Layouts, Import from file) and open a trial; `python -m dresslog.replay.foxglove
OUT.json` writes it out of the installed package.
"""

from __future__ import annotations

import json
import sys
from importlib import resources
from pathlib import Path
from typing import Any

LAYOUT_FILE = "foxglove_layout.json"


def layout_text() -> str:
    """The layout's JSON text, as shipped."""
    return resources.files("dresslog.replay").joinpath(LAYOUT_FILE).read_text(encoding="utf-8")


def layout() -> dict[str, Any]:
    """The layout as a dict (panels by id under `configById`, their arrangement `layout`)."""
    out: dict[str, Any] = json.loads(layout_text())
    return out


def main(argv: list[str]) -> int:
    """Write the layout to the file named, or print it."""
    if argv:
        Path(argv[0]).write_text(layout_text(), encoding="utf-8")
    else:
        sys.stdout.write(layout_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
