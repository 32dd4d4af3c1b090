"""``python -m tribofmu`` and the installed ``tribofmu`` command (its entry point: :func:`entry`)."""
import sys


def entry() -> int:
    """Ctrl-C and SIGTERM handled before the command's own imports: one line and exit 130 even
    in the first instants (the handlers raise KeyboardInterrupt, caught here or in main())."""
    from .progress import install_signal_handlers

    install_signal_handlers()
    try:
        from .cli import main
    except KeyboardInterrupt:
        print("tribofmu: interrupted; no result was written (earlier results are as they were)", file=sys.stderr)
        return 130
    return main()


if __name__ == "__main__":
    sys.exit(entry())
