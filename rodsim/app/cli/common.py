"""What every command shares: exit codes, the one-line user error, warnings, the scene as the
user named it (with ``--set`` overrides), the default output folder, and how a stability
verdict reads."""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rodsim.core.scene import Scene
    from rodsim.core.schema import SceneError
    from rodsim.core.stability import Stability

__all__ = ["EXIT_OK", "EXIT_SOLVER_FAILURE", "EXIT_BAD_INPUT", "EXIT_INTERRUPTED",
           "DEFAULT_OUTPUT_FOLDER",
           "UserError", "warn", "check_integrator", "output_path", "CREATED_FOLDERS",
           "remove_created_output_folder", "scene_error_text", "load_scene_or_fail",
           "stability_text"]

EXIT_OK, EXIT_SOLVER_FAILURE, EXIT_BAD_INPUT = 0, 1, 2
#: Ctrl-C or SIGTERM (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130

#: Folder (in the current folder) of every command's default output: a run's archive never
#: lands beside the sources of a checkout, and one ignore rule covers them (.gitignore).
DEFAULT_OUTPUT_FOLDER = Path("runs")


class UserError(Exception):
    """A problem with what the user asked for (exit code 2, one-line message)."""


def warn(message: str) -> None:
    """One ``rodsim: warning: …`` line on stderr (exit code unchanged)."""
    print(f"rodsim: warning: {message}", file=sys.stderr, flush=True)


def check_integrator(name: str | None) -> None:
    """``--integrator NAME`` must name a registered integrator (the registry is the only list
    of names; ``rodsim run --help`` lists them)."""
    from rodsim.solvers import registered_integrators

    names = registered_integrators()
    if name is not None and name not in names:
        raise UserError(f"--integrator {name!r}: unknown integrator; registered: "
                        + ", ".join(names))


#: The default output folder when this command created it (removed again if it stays
#: empty because the command ends in a bad-input error).
CREATED_FOLDERS: list[Path] = []


def output_path(given: str | None, default: str) -> Path:
    """The ``-o`` path if given, else ``runs/<default>`` in the current folder (the folder
    created if missing). An empty ``-o`` and one naming a folder (a trailing ``/``) are
    refused: a name was meant, and neither the default nor a file named like the folder
    is what was asked for."""
    if given is not None:
        if not given.strip():
            raise UserError("-o '': an empty output path; give a file name (or leave -o out "
                            "for the default)")
        if given.endswith(("/", os.sep)):
            raise UserError(f"-o {given[:60]!r}: names a folder; give a file name in it "
                            f"(e.g. {str(Path(given) / default)[:80]!r})")
        return Path(given)
    try:
        if not DEFAULT_OUTPUT_FOLDER.exists():
            DEFAULT_OUTPUT_FOLDER.mkdir()
            CREATED_FOLDERS.append(DEFAULT_OUTPUT_FOLDER.absolute())
    except OSError as exc:
        raise UserError(f"cannot create the output folder {str(DEFAULT_OUTPUT_FOLDER)!r} "
                        f"({exc.strerror or exc}); give an archive path with -o") from None
    return DEFAULT_OUTPUT_FOLDER / default


def remove_created_output_folder() -> None:
    """Remove the default output folder this command created, if it is still empty."""
    import contextlib

    while CREATED_FOLDERS:
        with contextlib.suppress(OSError):
            CREATED_FOLDERS.pop().rmdir()  # only an empty folder is removed


def scene_error_text(exc: SceneError) -> str:
    """A ``rodsim.core.schema.SceneError`` in the CLI's words: an override that could
    not be read names the ``--set`` it came from; other errors (a value out of range, a
    scene file) read the same as in Python."""
    from rodsim.core.schema import shown

    if exc.assignment is None:
        return str(exc)
    flag = f"--set {shown(exc.assignment, bare=True)}"
    # the keys an unknown or ambiguous key could be (a tuple), or a description
    names = exc.allowed if isinstance(exc.allowed, str) else ", ".join(exc.allowed or ())
    if exc.reason == "unknown key":
        closest = f"; closest: {names}" if names else ""
        return (f"{flag}: unknown key {shown(exc.key, bare=True)} (`rodsim run --help` "
                f"lists the keys){closest}")
    if exc.reason == "ambiguous key":
        return (f"{flag}: {exc.key} is ambiguous, could be {names} (give "
                "more of the dotted key)")
    if exc.reason == "expected key=value":
        return f"{flag}: expected KEY=VALUE"
    return f"{flag}: {exc.reason}"


def load_scene_or_fail(scene: str | None, overrides: Sequence[str],
                       integrator: str | None) -> Scene:
    """The fully validated scene the user named, ``--set`` overrides applied (those naming
    an option of ``integrator`` preferred); a one-line ``UserError`` otherwise."""
    from rodsim.app.api import load_scene
    from rodsim.core.scene import SceneError

    try:
        return load_scene(scene, overrides, f"solver.{integrator}" if integrator else "")
    except SceneError as exc:
        raise UserError(scene_error_text(exc)) from None


def stability_text(stability: Stability) -> str:
    """The summary line of a ``rodsim.core.stability.Stability`` verdict."""
    if stability.stable:
        return "stability   stable (the stiffness K = -dF/dx is positive definite)"
    if stability.neutral:
        return (f"stability   neutral: {stability.neutral_text} (eigenvalues of the "
                "diagonally scaled stiffness; none below): a mechanism or a rigid-body mode, "
                "the state is not unique (e.g. a rod free to turn about a ball joint)")
    return (f"warning     UNSTABLE equilibrium: the stiffness K = -dF/dx is not positive "
            f"definite ({stability.eigenvalue_text}); a small "
            "perturbation leaves it (e.g. a compressed rod past its buckling load)")
