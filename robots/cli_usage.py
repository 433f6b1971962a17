"""How both console scripts (`gaitsmith`, `gaitsmith-play`) run their typer app: every user
mistake is one line on stderr and an exit code — 2 for usage and input errors, 1 for a failed
check, 130 for Ctrl-C — never a traceback and never click's boxed usage panel.

It lives in `robots` because that is the one package both command-line packages import
(`hardware` never imports `gaitsmith`); it imports typer only, and no click (typer 0.2x vendors
click as `typer._click` and does not depend on it).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import typer

INTERRUPTED_EXIT_CODE = 130  # 128 + SIGINT, what shells report for Ctrl-C


def usage_error_type() -> type[Exception]:
    """The class of click's usage errors as this typer raises them.

    typer ≤ 0.1x raises `click.ClickException`s; typer 0.2x vendors click as `typer._click` and
    does not depend on click at all. Both make `typer.BadParameter` a subclass of the one they
    use, so it is found there — no `import click`, which a plain install may not have.
    """
    for cls in typer.BadParameter.__mro__:
        if cls.__name__ == "ClickException" and issubclass(cls, Exception):
            return cls
    return typer.BadParameter


def usage_message(exc: Exception) -> str:
    """click's usage error in one line: its message plus where to find help."""
    format_message = getattr(exc, "format_message", None)
    text = format_message() if callable(format_message) else str(exc)
    text = " ".join(str(text).split())  # one line, whatever click wrapped
    ctx = getattr(exc, "ctx", None)
    command_path = getattr(ctx, "command_path", None)
    return f"{text} (see '{command_path} --help')" if command_path else text


def run_app(
    app: typer.Typer,
    argv: Sequence[str] | None,
    user_errors: Callable[[], tuple[type[BaseException], ...]],
    report_error: Callable[[str], None],
    report_interrupted: Callable[[], None],
) -> int:
    """Run `app` on `argv` (None: the process's arguments) and return its exit code.
    `user_errors`: gives the exception classes whose message is meant for the user (reported as
    one line, exit 2), called only when an exception reaches here (so it can leave out the
    classes of modules the command never imported); `report_error` prints one line,
    `report_interrupted` the Ctrl-C notice."""
    try:
        code: Any = app(args=list(argv) if argv is not None else None, standalone_mode=False)
    except user_errors() as exc:  # evaluated only when an exception arrives
        report_error(str(exc))
        return 2
    except KeyboardInterrupt:
        report_interrupted()
        return INTERRUPTED_EXIT_CODE
    except typer.Exit as exc:  # raised outside the command (typer returns the code otherwise)
        code = exc.exit_code
    except typer.Abort as exc:  # typer ≤ 0.1x turns Ctrl-C into Abort
        if isinstance(exc.__cause__ or exc.__context__, KeyboardInterrupt):
            report_interrupted()
            return INTERRUPTED_EXIT_CODE
        report_error("aborted")
        return 1
    except usage_error_type() as exc:
        if type(exc).__name__ == "NoArgsIsHelpError":  # click ≥ 8.2: the command alone
            exc.show()  # type: ignore[attr-defined]  # prints the help
        else:
            report_error(usage_message(exc))
        return int(getattr(exc, "exit_code", 2))
    code = int(code) if isinstance(code, int) else 0
    if code == INTERRUPTED_EXIT_CODE:  # typer 0.2x turns Ctrl-C into Exit(130), returned here
        report_interrupted()
    return code
