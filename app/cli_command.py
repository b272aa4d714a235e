"""The class of every ``hydrodiag`` command: what each does around its own body.

* It runs as :data:`app.cli_support.running_command`, so that the one place the CLI
  opens the store (:func:`app.cli_support.migrated_engine`) knows whether the command may
  make one (:data:`app.cli_support.EXISTING_STORE_COMMANDS`: a listing run from a folder
  without a store made an empty one there; a review's leftover).
* A negative number where it takes a stored id is a wrong id, not an unknown option.
  ``hydrodiag history show -1`` answered "No such option: -1": click reads any word that
  starts with ``-`` as an option, so the id's own check (:func:`app.cli_support.
  store_id`, "ids run from 1") never saw it (a review's leftover).  Ids are the store's,
  from 1, as the API takes them (``GET /diagnoses/{id}``); a negative one is no index
  from the end.  The command says so, naming the argument, and where the ids are listed::

      $ hydrodiag history show -1
      Invalid value for 'diagnosis_id': -1 is not an id: ids run from 1 to 2147483647,
      and a negative one counts nothing from the end (`hydrodiag history list --limit 1`
      names the newest)
"""

from __future__ import annotations

import re
from typing import Any

import typer
from typer.core import TyperCommand

from app.cli_support import running_command, store_id

__all__ = ["HydrodiagCommand", "command_path", "use_command_class"]

#: the arguments that take a stored id, by name, and where their ids are listed
_LISTED = {
    "diagnosis_id": "`hydrodiag history list --limit 1` names the newest",
    "rig_id": "`hydrodiag rigs list` names them",
    "key_id": "`hydrodiag keys list` names them",
}
_NEGATIVE = re.compile(r"-\d+")


def _negative_id(command: Any, args: list[str]) -> str | None:
    """The first word of ``args`` that is a negative whole number and no option's value
    (``keys rotate 3 --grace -1`` gives ``--grace`` its -1), before a ``--``."""
    valued = {name for p in command.params if p.param_type_name == "option"
              and not (getattr(p, "is_flag", False) or getattr(p, "count", False))
              for name in (*p.opts, *p.secondary_opts)}
    previous = ""
    for word in args:
        if word == "--":
            return None
        if _NEGATIVE.fullmatch(word) and previous not in valued:
            return word
        previous = word
    return None


def command_path(ctx: Any) -> str:
    """The command's words after ``hydrodiag`` (``"history list"``)."""
    names: list[str] = []
    while ctx is not None and ctx.parent is not None:
        names.append(ctx.info_name or "")
        ctx = ctx.parent
    return " ".join(reversed(names))


class HydrodiagCommand(TyperCommand):
    """A command that runs as :data:`~app.cli_support.running_command` and refuses a
    negative stored id naming its argument (module docstring); other words are parsed as
    click parses them (a negative id was read as an unknown option)."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        """Refuse a negative id naming the argument; then parse as click does."""
        argument: Any = next((p for p in self.params if p.param_type_name == "argument"
                              and p.name in _LISTED), None)
        negative = None if argument is None else _negative_id(self, args)
        if argument is not None and negative is not None:
            try:
                store_id(negative)
            except typer.BadParameter as bad:
                raise typer.BadParameter(
                    f"{bad.message}, and a negative one counts nothing from the end "
                    f"({_LISTED[argument.name or '']})", ctx=ctx, param=argument) from None
        return list(super().parse_args(ctx, args))

    def invoke(self, ctx: Any) -> Any:
        """Run the command's body as :data:`~app.cli_support.running_command`."""
        token = running_command.set(command_path(ctx))
        try:
            return super().invoke(ctx)
        finally:
            running_command.reset(token)


def use_command_class(app: typer.Typer) -> None:
    """Give every command of ``app`` (and of its sub-apps) that has typer's command class
    :class:`HydrodiagCommand`."""
    for info in app.registered_commands:
        if info.cls in (None, TyperCommand):
            info.cls = HydrodiagCommand
    for group in app.registered_groups:
        if group.typer_instance is not None:
            use_command_class(group.typer_instance)
