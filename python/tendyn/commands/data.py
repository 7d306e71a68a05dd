"""``tendyn data list | path NAME``: the data sets shipped with tendyn (:mod:`tendyn.data`)."""

from __future__ import annotations

import argparse

from tendyn.errors import UsageError


def add_arguments(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("data", help="the data sets shipped with tendyn (tendyn data path tx40)")
    sub = p.add_subparsers(dest="action", required=True)
    sub.add_parser("list", help="the shipped data sets and what they hold").set_defaults(func=run_list)
    path = sub.add_parser("path", help="print the folder of a shipped data set (for shell scripts)")
    path.add_argument("name", help="data set name (tendyn data list)")
    path.set_defaults(func=run_path)
    return p


def run_list(args) -> int:
    from tendyn.data import DATASETS

    for name, what in sorted(DATASETS.items()):
        print(f"{name}: {what}")
    return 0


def run_path(args) -> int:
    from tendyn.data import path

    try:
        print(path(args.name))
    except KeyError as exc:
        raise UsageError(exc.args[0], "name") from None
    return 0


def register(subparsers) -> None:
    add_arguments(subparsers)
