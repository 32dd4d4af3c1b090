"""``python -m tribofmu`` and the installed ``tribofmu`` command (its entry point: :func:`entry`)."""
import sys

from .progress import install_signal_handlers, work_done


def entry() -> int:
    """Ctrl-C and SIGTERM handled before the command's own imports: one line and exit 130 even
    in the first instants (the handlers raise KeyboardInterrupt, caught here or in main())."""
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


if __name__ == "__main__":
    sys.exit(entry())
