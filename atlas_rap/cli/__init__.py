"""The ``atlas`` command line: the only part of atlas-rap that prints.

Ctrl-C is handled by :func:`atlas_rap.cli.main.main` (the line ``interrupted``,
exit 130). Two hooks, installed when the command line is imported, cover the
moments it cannot see:

- while the command is still starting (before ``main`` runs), a
  KeyboardInterrupt that nothing caught is the line ``interrupted``, not a
  traceback; the process then ends as Python ends one stopped by Ctrl-C (by
  SIGINT: status 130 in a shell);
- Ctrl-C that lands while Python is freeing an object (a callback of a
  compiled library, where Python can only print "Exception ignored") is
  delivered again a moment later, so the command still stops (unless it is
  already ending).

Its public name, :data:`cli` (the click group of the ``atlas`` command, which
``cli.main.main`` runs), is imported from ``cli.main`` at first use (``atlas_rap.exports``).
"""

import atexit
import signal
import sys
import threading

from atlas_rap.exports import lazy_exports, public_names

_EXPORTS = {"main": ("cli",)}

__all__ = public_names(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)


def _interrupted_quietly(kind, value, traceback, previous=sys.excepthook):
    if issubclass(kind, KeyboardInterrupt):
        print("interrupted", file=sys.stderr)
        return
    previous(kind, value, traceback)


def _interrupt_again(unraisable, previous=sys.unraisablehook):
    if not issubclass(unraisable.exc_type, KeyboardInterrupt):
        previous(unraisable)
    elif threading.current_thread() is threading.main_thread() and not sys.is_finalizing():
        signal.signal(signal.SIGALRM, _deliver)
        signal.setitimer(signal.ITIMER_REAL, 0.01)  # once this freeing is over


@atexit.register
def _no_alarm_at_exit() -> None:
    signal.setitimer(signal.ITIMER_REAL, 0)  # the process is ending anyway: its work is done


def _deliver(signum, frame):
    """Ctrl-C again: whatever SIGINT does now (KeyboardInterrupt, or the REPL's stop)."""
    handler = signal.getsignal(signal.SIGINT)
    if callable(handler):
        handler(signal.SIGINT, frame)


sys.excepthook = _interrupted_quietly
sys.unraisablehook = _interrupt_again
