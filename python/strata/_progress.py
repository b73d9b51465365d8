"""The text progress bar of `progress=True`: one line on stderr per task, redrawn in place."""

import sys
import time


class ProgressBar:
    """Called as bar(task, done, total) by the library's long operations."""

    def __init__(self, stream=None, width=30):
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.task = None
        self.finished = False
        self.start = 0.0

    def __call__(self, task, done, total):
        if task != self.task:
            if self.task is not None and not self.finished:
                self.stream.write("\n")
            self.task, self.finished, self.start = task, False, time.monotonic()
        elif self.finished:
            return  # the end of a task already drawn complete
        fraction = min(1.0, done / total) if total else 0.0
        filled = int(round(self.width * fraction))
        elapsed = time.monotonic() - self.start
        eta = elapsed * (1 - fraction) / fraction if fraction > 0 else 0.0
        self.stream.write(f"\r{task}: {100 * fraction:5.1f}% |{'#' * filled}{' ' * (self.width - filled)}| "
                          f"{elapsed:.1f}s elapsed, {eta:.1f}s left")
        if total and done >= total:
            self.stream.write("\n")
            self.finished = True
        self.stream.flush()
