"""The ``ridsafe`` command line: argument parsing and one ``*_cmd`` module per subcommand.

``main`` (the console script ``ridsafe``; ``python -m ridsafe.tools.cli``) is in ``entry_point``;
``app_args`` holds the arguments every app command shares. What the commands run lives in
``ridsafe.tools.run`` (cores, lockstep, live), ``runlog``, ``analysis`` and ``sweep``.
"""

from ridsafe.tools.cli.entry_point import build_parser, main

__all__ = ["build_parser", "main"]
