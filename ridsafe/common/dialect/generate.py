"""Regenerate the committed pymavlink module of the ridsafe dialect.

The dialect XML includes common.xml; mavgen resolves includes next to the XML, so the
generation runs in a temporary folder holding our XML and the installed pymavlink's own
common.xml, standard.xml and minimal.xml (nothing of pymavlink is copied into the repo).

    python -m ridsafe.common.dialect.generate            # rewrite ridsafe_v20.py
    python -m ridsafe.common.dialect.generate --out X.py # write elsewhere (the test does)
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pymavlink

DIALECT_DIR = Path(__file__).resolve().parent
DIALECT_XML = DIALECT_DIR / "ridsafe.xml"
GENERATED_MODULE = DIALECT_DIR / "ridsafe_v20.py"
_INCLUDED_XMLS = ("common.xml", "standard.xml", "minimal.xml")


def generate(out_path: Path) -> None:
    """Run mavgen (Python3, wire protocol 2.0) on the dialect and write ``out_path``."""
    upstream = Path(pymavlink.__file__).resolve().parent / "dialects" / "v20"
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in _INCLUDED_XMLS:
            shutil.copyfile(upstream / name, work / name)
        shutil.copyfile(DIALECT_XML, work / DIALECT_XML.name)
        target = work / "ridsafe_v20.py"
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pymavlink.tools.mavgen",
                "--lang=Python3",
                "--wire-protocol=2.0",
                f"--output={target}",
                str(work / DIALECT_XML.name),
            ],
            check=True,
            cwd=work,
            capture_output=True,
        )
        shutil.copyfile(target, out_path)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=GENERATED_MODULE)
    args = parser.parse_args()
    generate(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
