"""``python -m tribofmu`` and the installed ``tribofmu`` command (its entry point: :func:`entry`)."""
import sys

from .progress import install_signal_handlers, work_done


def entry() -> int:
    """Ctrl-C and SIGTERM handled before the command's own imports: one line and exit 130 even
    in the first instants (the handlers raise KeyboardInterrupt, caught here or in main())."""
    status = _run()
    exit_now_if_interrupted(status)
    return status


def _run() -> int:
    install_signal_handlers(own_process=True)
    try:
        from .cli import main  # after the handlers: a Ctrl-C during the CLI's imports is one line too
        status = main()
        work_done()  # a signal during the teardown does not replace the finished work's status
        return status
    except KeyboardInterrupt:  # before the command's own handler, or one escaping it (a signal
        # arriving while a Dask cluster starts or stops): still one line and 130, not a
        # death by SIGINT with nothing said
        print("tribofmu: interrupted; no result was written (earlier results are as they were)", file=sys.stderr)
        return 130


def exit_now_if_interrupted(status: int) -> None:
    """After an interruption's one line: the exit handlers (temporary files) run, and the
    process ends with 130 at once. Left to the interpreter's own shutdown, ``python -m
    tribofmu`` ended by SIGINT (returncode -2) after its line in 3 to 4 of 40 Ctrl-Cs sent
    between 0.1 and 0.5 s after the start (2026-11-27; the installed command in none of 80):
    the shutdown has nothing left to do that is worth that."""
    if status != 130:
        return
    import atexit
    import os

    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(130)


if __name__ == "__main__":
    sys.exit(entry())
