"""Make the pictures of the README and the docs' home page: the demo's 3-D scene (three trees
of the paper's forest, a flown circle, pulse positions and lobes), resized for the page.

    python tools/make_readme_images.py        # writes docs/images/scene_3d.png
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
WIDTH_PX = 1000


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "batecho", "demo", "--out", tmp, "-q"], check=True)
        image = Image.open(Path(tmp) / "scene_3d.png")
        if image.width > WIDTH_PX:
            height = round(image.height * WIDTH_PX / image.width)
            image = image.resize((WIDTH_PX, height), Image.LANCZOS)
        out = ROOT / "docs" / "images" / "scene_3d.png"
        image.save(out, optimize=True)
    print(f"wrote {out} ({out.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main()
