"""Entry point of the ``dualpose`` command, outside the :mod:`dualpose` package on purpose.

Importing :mod:`dualpose.cli.main` first runs ``dualpose/__init__.py``, which imports the algebra and NumPy (about
0.1--0.3 s).  A Ctrl-C in that time would end in a ``KeyboardInterrupt`` traceback printed by the caller, before
:func:`dualpose.cli.main.main` and its guard run, or in an ``ImportError`` (NumPy turns an exception raised while its
extension modules load into one).  This module imports nothing of dualpose's, so that the heavy
imports happen inside :func:`main`, where a Ctrl-C exits with status 130 quietly.  ``import dualpose`` never imports
it: a library user's signal handling is left alone.
"""

import os  # both already loaded by the interpreter: the module's body takes microseconds
import sys

#: exit status on Ctrl-C (128 + SIGINT), as :data:`dualpose.cli.main.EXIT_INTERRUPTED`
_EXIT_INTERRUPTED = 130


def main(unblock_sigint: bool = False) -> int:
    """Import the command line and run it (``dualpose.cli.main.main``); Ctrl-C while importing exits 130.

    ``unblock_sigint``: SIGINT was blocked by the launcher; unblocked once the handler is in place, so that a Ctrl-C
    pending since the interpreter's start-up is delivered to it.
    """
    caught: list[int] = []

    def interrupted(signum: int, frame: object) -> None:
        # Nothing of the command has run yet, so the process ends here at once.  Raising KeyboardInterrupt instead
        # is not quiet: when the signal lands in a callback the import system runs (a module lock's weakref
        # callback), CPython prints "Exception ignored in ..." with the traceback and goes on importing.
        caught.append(signum)
        os._exit(_interrupted())

    try:
        import signal  # (imports enum: a few ms, inside the guard)

        # only Python's default handler is replaced (an inherited SIG_IGN, as in a background job, stays)
        replace = signal.getsignal(signal.SIGINT) is signal.default_int_handler
        if replace:
            signal.signal(signal.SIGINT, interrupted)
        if unblock_sigint:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        try:
            from dualpose.cli.main import main as run
        finally:
            if replace:
                signal.signal(signal.SIGINT, signal.default_int_handler)
    except BaseException as exc:
        if not (caught or isinstance(exc, KeyboardInterrupt)):
            raise  # a broken installation: its own traceback
        return _interrupted()
    try:
        return run()  # its own guard covers the command; this, the microseconds before it
    except KeyboardInterrupt:
        return _interrupted()


def _interrupted() -> int:
    try:
        sys.stdout.flush()
    except (OSError, ValueError):
        pass
    return _EXIT_INTERRUPTED
