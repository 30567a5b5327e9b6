"""What every module of the study shares: its log line, its error, and files
written whole or not at all."""
import os
import sys
import tempfile


def log(msg):
    print(msg, file=sys.stderr, flush=True)


class RunFailed(Exception):
    """A run failed; penumbra said why (on stderr, or in the message)."""

    def __init__(self, message, status=1):
        super().__init__(message)
        self.status = status


def format_seconds(s):
    if s < 60:
        return f"{s:.1f}s"
    if s < 3600:
        return f"{int(s) // 60}m{int(s) % 60:02d}s"
    return f"{int(s) // 3600}h{(int(s) % 3600) // 60:02d}m"


def write_atomic(path, write):
    """write(tmp_path) makes the file; it replaces `path` only when complete (never a half-written report)."""
    folder, base = os.path.split(os.path.abspath(path))
    stem, ext = os.path.splitext(base)
    fd, tmp = tempfile.mkstemp(prefix="." + stem + ".tmp-", suffix=ext, dir=folder)
    os.close(fd)
    try:
        write(tmp)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_text(path, text):
    def w(tmp):
        with open(tmp, "w") as f:
            f.write(text)
    write_atomic(path, w)


def checks_passed(what, failures):
    """Logs each failure as 'study: <what> FAILED: ...'; True when there is none."""
    for f in failures:
        log(f"study: {what} FAILED: " + f)
    return not failures
