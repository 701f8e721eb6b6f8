#!/usr/bin/env python3
"""Writes docs/limits.md from the one table of limits (``illumap.limits``) and the one
declaration of the settings (``illumap.settings``).

Usage: .venv/bin/python scripts/limits_page.py          (write the page)
       .venv/bin/python scripts/limits_page.py --check  (exit 1 when the page is out of date)
"""

import os
import sys

from illumap import settings

PAGE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs",
                    "limits.md")


def main(argv) -> int:
    if argv not in ([], ["--check"]):
        print(__doc__, file=sys.stderr)
        return 2
    text = settings.page()
    if argv == ["--check"]:
        with open(PAGE, encoding="utf-8") as f:
            if f.read() != text:
                print(f"{PAGE} is out of date: run scripts/limits_page.py", file=sys.stderr)
                return 1
        return 0
    with open(PAGE, "w", encoding="utf-8") as f:
        f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
