"""Python denoisers for tests/python/test_tandem.py: an exponential moving average of the noisy
radiance (restarted on reset) and one that fails."""
import numpy as np


class Ema:
    def __init__(self, width, height):
        self.prev = None

    def __call__(self, frame):
        x = np.array(frame.radiance)
        if self.prev is not None and not frame.reset:
            x = 0.75 * self.prev + 0.25 * x
        self.prev = x
        return x


def broken(width, height):
    def run(frame):
        raise ValueError("no luck at frame %d" % frame.index)
    return run


class Identity:
    """The noisy radiance unchanged: a render through it is --denoiser off's."""

    def __init__(self, width, height):
        pass

    def __call__(self, frame):
        return frame.radiance
