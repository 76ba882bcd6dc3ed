"""The application layer: the ``hvacfmu`` command, the demo, its report and figures.

It sits on top of every other layer (``hvacfmu`` library and ``harness``) and may import
any of them; nothing imports it. The entry point is :func:`main` (``hvacfmu.cli:main``).

- :mod:`.commands`: argument parsing, one library call per command;
- :mod:`.demo`, :mod:`.demo_results`, :mod:`.demo_report`, :mod:`.demo_plots`: ``hvacfmu demo``;
- :mod:`.report`: a small HTML/Markdown report writer.
"""

from __future__ import annotations

from .commands import build_parser, main

__all__ = ["build_parser", "main"]
