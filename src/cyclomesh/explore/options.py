"""The options of ``cyclomesh explore`` (kept here so the command line stays thin)."""

from __future__ import annotations

from typing import Annotated

import typer

__all__ = ["PortOption", "NoBrowserOption"]

PortOption = Annotated[
    int, typer.Option(min=0, max=65535, help="Port on 127.0.0.1 (0: any free port).")
]
NoBrowserOption = Annotated[bool, typer.Option("--no-browser", help="Do not open a browser.")]
