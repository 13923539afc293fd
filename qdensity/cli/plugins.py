"""Sub-commands that other packages add to the ``qdensity`` command.

A package adds a sub-command by declaring an entry point in the group ``qdensity.commands``
whose value is a function taking the command's sub-parsers (what
``argparse.ArgumentParser.add_subparsers`` returns) and adding its parser there, with
``set_defaults(func=...)`` naming the function that runs it and returns the exit status::

    [project.entry-points."qdensity.commands"]
    experiment = "qdensity_paper.cli.experiment:add_parser"

The paper's reproduction (the ``qdensity_paper`` package in the ``paper/`` folder of the
repository) adds ``qdensity experiment`` and ``qdensity results`` this way. Where it is not
installed, those two commands still exist and say how to install it.

:func:`command_texts` words a sub-command's ``--help`` the way the built-in commands do.
"""

from __future__ import annotations

import argparse
import sys
from importlib.metadata import entry_points
from typing import Any, TypedDict

from qdensity.validation import Instance, validates

__all__ = ["GROUP", "NOT_INSTALLED", "add_plugin_parsers", "command_texts", "CommandTexts"]

#: The entry-point group read for sub-commands.
GROUP = "qdensity.commands"

#: Sub-commands of packages that are not installed: name -> (what it is, how to install it).
NOT_INSTALLED: dict[str, tuple[str, str]] = {
    name: ("the paper's reproduction (the qdensity_paper package)",
           "pip install -e paper   # from a clone of the qdensity repository")
    for name in ("experiment", "results")
}


class CommandTexts(TypedDict):
    """The keyword arguments :func:`command_texts` gives ``add_parser``.

    Examples
    --------
    >>> texts = command_texts("Say hello.", "qdensity hello")
    >>> sorted(texts) == sorted(CommandTexts.__annotations__)
    True
    """

    description: str
    epilog: str


@validates(description=Instance(str), examples=Instance(str))
def command_texts(description: str, examples: str) -> CommandTexts:
    """``description=`` and ``epilog=`` for ``add_parser``: the description as written and an
    ``examples:`` block of one command per line.

    Parameters
    ----------
    description : str
        What the command does (line breaks are kept).
    examples : str
        Example command lines, one per line.

    Returns
    -------
    CommandTexts
        ``{"description": ..., "epilog": "examples:\\n  ..."}``.

    Examples
    --------
    >>> command_texts("Say hello.", "qdensity hello")["epilog"]
    'examples:\\n  qdensity hello'
    """
    lines = "\n".join(f"  {line}" for line in examples.splitlines())
    return {"description": description, "epilog": f"examples:\n{lines}"}


def _missing(name: str):
    what, install = NOT_INSTALLED[name]

    def run(args: Any) -> int:
        print(f"qdensity {name}: this command comes with {what}, which is not installed; "
              f"install it with: {install}", file=sys.stderr)
        return 2

    return run


def add_plugin_parsers(sub: Any) -> list[str]:
    """Add every installed package's sub-commands (entry-point group :data:`GROUP`) to
    ``sub``, and a stand-in for each command of :data:`NOT_INSTALLED` that none added.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        What ``ArgumentParser.add_subparsers`` returned.

    Returns
    -------
    list of str
        The names of the sub-commands that installed packages added.

    Examples
    --------
    The paper's commands are there either way: the installed package's, or stand-ins that say what
    to install:

    >>> import argparse
    >>> sub = argparse.ArgumentParser(prog="qdensity").add_subparsers()
    >>> added = add_plugin_parsers(sub)
    >>> set(NOT_INSTALLED) <= set(sub.choices), set(added) <= set(sub.choices)
    (True, True)
    """
    added: list[str] = []
    for point in sorted(entry_points(group=GROUP), key=lambda p: p.name):
        if point.name in sub.choices:  # a built-in command is never replaced
            continue
        point.load()(sub)
        added.append(point.name)
    for name, (what, install) in NOT_INSTALLED.items():
        if name not in sub.choices:
            stand_in = sub.add_parser(name, help=f"(needs {what}: {install})", add_help=False,
                                      description=f"Not installed: {what}. Install it with: "
                                                  f"{install}")
            stand_in.add_argument("words", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
            stand_in.set_defaults(func=_missing(name))
    return added
