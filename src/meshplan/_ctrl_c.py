"""What Ctrl-C does in the ``meshplan run`` program: end it at once while nothing is written, and
raise :class:`KeyboardInterrupt` (so that what was begun is cleaned up) once the files are.

A :class:`KeyboardInterrupt` raised wherever the main thread happens to be is not always reported
as one: raised inside a library's import of a compiled module it came out as ``ImportError:
initialization failed`` (an internal error), and an import guarded by ``except ImportError``
would swallow it (the run went on and wrote its files: exit status 0 after a Ctrl-C, seen under
load); in the middle of a compiled module's initialization it crashed the interpreter (a tuple
left holding NULL, iterated: SIGSEGV, nothing printed). Until the run stages its output
directory (:func:`meshplan.io.staged_directory`) there is nothing to clean up: the drawing
workers die with the run (``PR_SET_PDEATHSIG``), nothing has been created on disk, so the
program says so in one line and exits at once, without unwinding through the libraries.
"""

from __future__ import annotations

import os
import signal
import threading
from typing import Any

#: What the program prints on Ctrl-C (stderr), before exiting with status 130.
MESSAGE = "error: interrupted; nothing was written"
#: The exit status after Ctrl-C (128 + SIGINT), as shells report it.
STATUS = 130


#: Written before the message on a terminal: the cursor shown again (the progress display hides
#: it, and exiting at once leaves it no chance to show it) and a new line (the display's last
#: line, or the ``^C`` the terminal echoed, ends where the cursor stands).
_ON_A_TERMINAL = "\x1b[?25h\n"


def exit_at_once(signum: int, frame: Any) -> None:
    """The program's Ctrl-C handler while nothing is written: one line, exit 130. Written with
    ``os.write``: the main thread may have been interrupted inside ``sys.stderr.write``, whose
    buffer would refuse a reentrant call."""
    try:
        lead = _ON_A_TERMINAL if os.isatty(2) else ""
    except OSError:  # stderr closed
        lead = ""
    try:
        os.write(2, (lead + MESSAGE + "\n").encode())
    except OSError:  # nowhere to say it
        pass
    os._exit(STATUS)


def exit_at_once_from_now() -> None:
    """Make Ctrl-C end the program at once (:func:`exit_at_once`), from the main thread of a
    process whose Ctrl-C raises :class:`KeyboardInterrupt` (Python's default: a program started
    with Ctrl-C ignored keeps ignoring it, a library's caller keeps its own handler)."""
    if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, exit_at_once)


def raise_from_now() -> None:
    """Make Ctrl-C raise :class:`KeyboardInterrupt` again where :func:`exit_at_once_from_now` had it
    end the program: from the moment something is created on disk, which the exception's
    handlers remove (anywhere else, and in any other thread, this does nothing)."""
    if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is exit_at_once:
        signal.signal(signal.SIGINT, signal.default_int_handler)
