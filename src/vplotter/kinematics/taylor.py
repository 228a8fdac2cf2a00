"""Second-order Taylor arithmetic on (value, first, second derivative) triples of arrays: the
exact derivatives of the V-plotter's cords along a straight line (kinematics/vplotter.py and
the tilting gondola, kinematics/tilt.py, and the sagging cords, kinematics/sag.py)."""

from __future__ import annotations

import numpy as np


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(a, k):
    return (a[0] * k, a[1] * k, a[2] * k)


def mul(a, b):
    return (a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + 2.0 * a[1] * b[1] + a[0] * b[2])


def div(a, b):
    q = a[0] / b[0]
    q1 = (a[1] - q * b[1]) / b[0]
    return (q, q1, (a[2] - 2.0 * q1 * b[1] - q * b[2]) / b[0])


def sqrt(a):
    r = np.sqrt(a[0])
    r1 = a[1] / (2.0 * r)
    return (r, r1, (a[2] - 2.0 * r1 * r1) / (2.0 * r))


def cos_sin(a, c=None, s=None):
    """cos and sin of a triple (c, s: cos and sin of its value, when known)."""
    c = np.cos(a[0]) if c is None else c
    s = np.sin(a[0]) if s is None else s
    d1, d2 = a[1], a[2]
    sq = d1 * d1
    return (c, -s * d1, -c * sq - s * d2), (s, c * d1, -s * sq + c * d2)


def sinh(a):
    sh, ch = np.sinh(a[0]), np.cosh(a[0])
    return (sh, ch * a[1], sh * a[1] * a[1] + ch * a[2])


def asinh(a):
    """asinh: f' = 1 / sqrt(1 + a^2), f'' = -a / (1 + a^2)^(3/2)."""
    inv = 1.0 / np.sqrt(1.0 + a[0] * a[0])
    return (np.arcsinh(a[0]), a[1] * inv, (a[2] - a[0] * a[1] * a[1] * inv * inv) * inv)


class First:
    """The same arithmetic on (value, first derivative) pairs, where no second derivative is
    needed (kinematics/sag.py's Newton steps and Jacobians): half the work."""

    @staticmethod
    def add(a, b):
        return (a[0] + b[0], a[1] + b[1])

    @staticmethod
    def sub(a, b):
        return (a[0] - b[0], a[1] - b[1])

    @staticmethod
    def scale(a, k):
        return (a[0] * k, a[1] * k)

    @staticmethod
    def mul(a, b):
        return (a[0] * b[0], a[1] * b[0] + a[0] * b[1])

    @staticmethod
    def div(a, b):
        q = a[0] / b[0]
        return (q, (a[1] - q * b[1]) / b[0])

    @staticmethod
    def sqrt(a):
        r = np.sqrt(a[0])
        return (r, a[1] / (2.0 * r))

    @staticmethod
    def sinh(a):
        return (np.sinh(a[0]), np.cosh(a[0]) * a[1])

    @staticmethod
    def asinh(a):
        return (np.arcsinh(a[0]), a[1] / np.sqrt(1.0 + a[0] * a[0]))

    @staticmethod
    def cos_sin(a):
        c, s = np.cos(a[0]), np.sin(a[0])
        return (c, -s * a[1]), (s, c * a[1])
