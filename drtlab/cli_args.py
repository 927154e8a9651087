"""Command-line plumbing shared by every drtlab command (and `python -m drtlab.experiments.*`
tools): an argparse parser whose usage errors are one `InputError` line, help that shows defaults,
flag types built from `drtlab.fields` checks, and the `main` wrapper that prints bad input as
`drtlab: FIELD: message` with exit code 2."""
from __future__ import annotations

import argparse
import re
import sys

from drtlab import fields
from drtlab.errors import InputError

EXIT_BAD_INPUT = 2
# A reader that closed the pipe (`drtlab scenes | head -1`) ends the command as SIGPIPE would.
EXIT_BROKEN_PIPE = 128 + 13


class Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (`drtlab: --spp: ...`) and exit code 2, and every
    word that starts with a minus and a digit is a value: argparse reads only plain negative numbers
    so, and took `--res -16x12` or `--albedo -1,0,0` for an option without its value."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # argparse's own switch for what counts as a negative number (no drtlab option starts with
        # a digit, so none is mistaken for a value).
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def _print_message(self, message, file=None):
        # argparse drops a failed write of --help or --version and exits 0; a full disk or a closed
        # pipe must reach run_main like any other output error (exit 2, or 141 for the pipe).
        if message:
            (file or sys.stderr).write(message)
            (file or sys.stderr).flush()

    def error(self, message: str):
        m = re.match(r"argument ([^:]+): (.*)", message)
        if m:
            raise InputError(m.group(1).split("/")[-1], m.group(2))
        m = re.match(r"the following arguments are required: (.*)", message)
        if m:
            raise InputError(m.group(1), "required")
        m = re.match(r"unrecognized arguments: (.*)", message)
        if m:
            extra = m.group(1).split()[0]
            if extra.startswith("-"):
                raise InputError(extra, f"unknown option; see `{self.prog} --help`")
            # A value too many: `--res 32 24` for `--res 32x24`.
            raise InputError(extra, f"unexpected argument (each option takes one value); see `{self.prog} --help`")
        raise InputError("arguments", message)


class Given(argparse.Action):
    """Stores a flag's value as argparse does and notes that the command line gave it: a check can
    tell `--seed 0` from the default 0 (`given_flags`)."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        setattr(namespace, "given_flags", given_flags(namespace) | {self.dest})


def given_flags(args) -> set[str]:
    """The dests of the `Given` flags the command line set."""
    return getattr(args, "given_flags", set())


class Help(argparse.ArgumentDefaultsHelpFormatter):
    """Shows a flag's default where it has one; defaults that depend on the scene say so in words."""

    def _get_help_string(self, action):
        # A switch (store_true / store_false) says what it does; "(default: True)" would not.
        if action.default is None or isinstance(action.default, bool) or action.default is argparse.SUPPRESS:
            return action.help
        return super()._get_help_string(action)


def flag(check, *args):
    """An argparse `type` from a `drtlab.fields` check; the parser puts the flag's name in front."""
    def parse(text: str):
        try:
            return check(text, "", *args)
        except InputError as e:
            raise argparse.ArgumentTypeError(e.message) from None
    return parse


def int_flag(low: int, high: int | None = None):
    return flag(fields.int_text, low, high)


def _resolution_text(text: str, field: str) -> str:
    """`N` or `WxH`, checked now; `N` takes its height from each scene's aspect later."""
    fields.resolution(text, field, aspect=1.0)
    return text


resolution_flag = flag(_resolution_text)


def path_flag(text: str):
    """A path flag's value as a Path; an empty one is refused (Path('') is the current folder)."""
    from pathlib import Path
    return Path(flag(fields.path_text)(text))




def _silence_stdout() -> None:
    """Point stdout at /dev/null: the interpreter flushes it once more at exit, and that flush into
    the closed pipe would print an 'Exception ignored' traceback."""
    import os
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):      # stdout replaced (pytest's capture)
        pass


class OutputError(OSError):
    """stdout cannot take the command's output (a full disk: `> /dev/full`)."""


class _Forgiving:
    """The process's stderr, dropping what it cannot write (`2> /dev/full`): a warning or a progress
    line never stops the work it is about, and a bad-input line that cannot be shown still ends in
    exit 2."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text):
        try:
            return self._stream.write(text)
        except (OSError, ValueError):
            return len(text)

    def flush(self):
        try:
            self._stream.flush()
        except (OSError, ValueError):
            pass

    def __getattr__(self, name):
        return getattr(self._stream, name)


class _Output(_Forgiving):
    """The process's stdout, whose write errors other than a closed pipe are an OutputError."""

    def write(self, text):
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OutputError(exc.errno, exc.strerror) from None

    def flush(self):
        try:
            self._stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OutputError(exc.errno, exc.strerror) from None


def _guard_streams():
    """Make the standard streams safe to use; returns (whether stdout was closed, a function that
    puts sys.stdout and sys.stderr back). A closed fd 1 or 2 (`>&-`, `2>&-`) is opened on /dev/null
    first: else the next file the command opens (a scene, an image) would take its number, and a
    print could land in it. A closed stderr then swallows its lines (its bad-input line included:
    they went to stdout, with exit 1); the process's own streams get the wrappers above (a test's
    captured streams are left alone)."""
    import os
    saved = sys.stdout, sys.stderr
    closed = []
    for fd in (1, 2):
        try:
            os.fstat(fd)
        except OSError:
            devnull = os.open(os.devnull, os.O_WRONLY)
            if devnull != fd:
                os.dup2(devnull, fd)
                os.close(devnull)
            closed.append(fd)
    if sys.stderr is None:
        sys.stderr = open(os.devnull, "w")
    if sys.stdout is None:
        sys.stdout = open(os.devnull, "w")
    if sys.stderr is sys.__stderr__:
        sys.stderr = _Forgiving(sys.stderr)
    if sys.stdout is not None and sys.stdout is sys.__stdout__:
        sys.stdout = _Output(sys.stdout)

    def restore():
        sys.stdout, sys.stderr = saved
    return 1 in closed or saved[0] is None, restore


def run_main(build_parser, argv: list[str] | None = None, prepare=None) -> int:
    """Parse and run a command; bad input is one stderr line and exit 2, Ctrl-C exit 130, a closed
    output pipe exit 141 without a word; a closed stdout is refused before the work, and a full one
    is one line, exit 2. `prepare(argv)` runs first, under the same rules (the `drtlab` program
    loads its plugins there)."""
    stdout_closed, restore = _guard_streams()
    try:
        return _run_main(build_parser, argv, prepare, stdout_closed)
    finally:
        restore()


def _run_main(build_parser, argv, prepare, stdout_closed: bool) -> int:
    try:
        try:
            if stdout_closed:
                raise InputError("stdout", "is closed (>&-): drtlab prints what it did there; send it "
                                           "to /dev/null (> /dev/null) to discard it")
            if prepare is not None:
                prepare(sys.argv[1:] if argv is None else list(argv))
            args = build_parser().parse_args(argv)
            code = args.func(args)
        finally:
            sys.stdout.flush()          # inside the try: a closed pipe shows up here at the latest
        return code
    except BrokenPipeError:
        _silence_stdout()
        return EXIT_BROKEN_PIPE
    except OutputError as e:
        _silence_stdout()
        print(f"drtlab: stdout: cannot write the output: {e.strerror}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except InputError as e:
        print(f"drtlab: {e.field}: {e.message}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("drtlab: interrupted", file=sys.stderr)
        return 130


def show_progress(args) -> bool:
    """A progress bar only for a person watching: not with --no-progress, not into a log."""
    return not args.no_progress and sys.stdout.isatty() and sys.stderr.isatty()


def add_cache_and_threads(parser) -> None:
    from pathlib import Path
    parser.add_argument("--gt-dir", type=path_flag, default=None,
                        help="ground-truth cache (default: $DRTLAB_GT_DIR or results/ground-truth)")
    parser.add_argument("--threads", type=int_flag(1, 1024), default=None,
                        help="CPU threads per render (default: all cores)")


def add_progress_flag(parser) -> None:
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress bar (there is none either when output goes to a file or pipe)")


def parse_overrides(pairs: list[str] | None) -> dict:
    """`--set key=value` pairs as scene overrides; a value is read as TOML (`[1, 2]`, `0.5`, `true`,
    `"text"`), and a bare word that is not TOML is taken as a string."""
    import tomllib
    out: dict = {}
    for pair in pairs or []:
        key, sep, text = pair.partition("=")
        if not sep or not key.strip():
            raise InputError("--set", f"must look like key=value (e.g. camera.fov=30), got {pair!r}")
        try:
            value = fields.check_nesting(tomllib.loads(f"v = {text}")["v"], "--set")
        except tomllib.TOMLDecodeError:
            value = text
        except RecursionError:
            raise fields.too_deep("--set") from None
        out[key.strip()] = value
    return out
