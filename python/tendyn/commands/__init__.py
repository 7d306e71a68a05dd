"""Subcommands of `tendyn` beyond the core ones of :mod:`tendyn.cli`, one module each.

Each module defines ``register(subparsers)``, which adds its subparser(s) with ``set_defaults(func=…)``;
:func:`tendyn.cli.build_parser` finds every module here by itself, so a new command needs no edit of
``cli.py``. Handlers parse and call, like ``cli.py``: bad input raises :class:`tendyn.errors.UsageError`
(exit 2), a failed result check :class:`tendyn.errors.CheckFailed` (exit 1). Option values use the typed
converters of :mod:`tendyn.commands.args`.
"""
