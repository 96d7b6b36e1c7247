"""Domain errors and the process exit codes they map to (documented in README)."""
from __future__ import annotations

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2
EXIT_INPUT_MISSING = 3
EXIT_BAD_LOG = 4
EXIT_BAD_PARAMETERS = 5
EXIT_NOT_IDENTIFIABLE = 6
EXIT_OUTPUT = 7
EXIT_SOME_FAILED = 8  # batch: at least one log failed, at least one succeeded
EXIT_ALL_FAILED = 9  # batch: every log failed
EXIT_INADEQUATE = 10  # --strict: the model does not fit the log (model_check.adequate is false)
EXIT_UNDECIDED = 11  # --strict: whether the model fits is not decided (model_check.adequate is null: the fit did
# not converge and could still reach the noise level, or the log's noise floor cannot be measured, the model
# simulates it as well as a black box and its halves give the same J/B)
EXIT_INTERRUPTED = 130  # Ctrl-C, as a shell reports it
EXIT_PIPE_CLOSED = 141  # the reader of stdout went away (`--json - | head`), as a shell reports a SIGPIPE


class TrmsError(Exception):
    """Base class: one-line message, fixed exit code."""

    exit_code = EXIT_INTERNAL


class InputNotFoundError(TrmsError, FileNotFoundError):
    exit_code = EXIT_INPUT_MISSING


class LogFormatError(TrmsError, ValueError):
    """The log cannot be used: message names the file, row or time, and what was expected."""

    exit_code = EXIT_BAD_LOG


class JoinedRunsError(LogFormatError):
    """The file breaks into parts: several runs joined end to end (time restarts, or the angles jump farther in
    one sample than the bench can move), or gaps in its stamps (rows lost, a logger's pause).  ``runs`` holds
    each part as a validated Log, for a joint estimate; ``found`` says what was found ("log.csv: holds 3 runs
    joined end to end (line ...: time restarts; ...)"); ``gaps``: each gap's {"after_s", "length_s", "where"}
    (empty for joined runs)."""

    def __init__(self, found: str, runs: list, expected: str = "expected one run: estimate them as runs of one "
                 "bench with --joint, or split the file", gaps: list | None = None):
        super().__init__(f"{found}; {expected}")
        self.found, self.runs, self.gaps = found, runs, list(gaps or [])


class ParameterFileError(TrmsError, ValueError):
    exit_code = EXIT_BAD_PARAMETERS


class SettingsError(TrmsError, ValueError):
    """An option value is out of range (e.g. a negative filter bandwidth)."""

    exit_code = EXIT_USAGE


class IdentificationError(TrmsError, RuntimeError):
    """The log does not excite the parameters enough to identify them."""

    exit_code = EXIT_NOT_IDENTIFIABLE


class OutputError(TrmsError, OSError):
    exit_code = EXIT_OUTPUT
