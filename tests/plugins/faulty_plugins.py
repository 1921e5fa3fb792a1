"""Plug-ins that misbehave on purpose, for the tests: each must fail only its own trials, with
the reason recorded, and never the run."""

import time


class _Base:
    level = "tracker"

    def __init__(self, info):
        self.info = info
        self.pushes = 0

    def push(self, input):
        self.pushes += 1
        return None


class RaisesOnTrialOne(_Base):
    """Raises on its 50th input in the trials whose seed has bit 7 set: some trials pass, some fail."""

    def push(self, input):
        super().push(input)
        if self.pushes == 50 and (self.info.seed >> 7) & 1:
            raise ZeroDivisionError("the plug-in's own bug")
        return None


class Malformed(_Base):
    """Returns a point with three coordinates."""

    def push(self, input):
        return (1.0, 2.0, 3.0)


class NotFinite(_Base):
    def push(self, input):
        return (float("nan"), 1.0)


class BadTokens(_Base):
    level = "tokens"

    def push(self, input):
        return [("BIT2", input.end_ns)]


class TokenFromTheFuture(_Base):
    level = "tokens"

    def push(self, input):
        return [("NULL", input.end_ns + 1)]


class Hangs(_Base):
    """Sleeps far past any time limit on its 10th input."""

    def push(self, input):
        super().push(input)
        if self.pushes == 10:
            time.sleep(3600)
        return None


class Exits(_Base):
    def push(self, input):
        import os

        os._exit(3)


class NoLevel:
    def __init__(self, info):
        pass


class Prints(_Base):
    """Prints on every input: standard output must not reach the pipe."""

    def push(self, input):
        print("hello from the plug-in", input.seq)
        return None
