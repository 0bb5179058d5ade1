"""What the fuzz tests share: their hypothesis settings and the one check of a mutated file.

``FAST`` runs in the default suite (seeded by ``derandomize``, few examples, a deadline against
hangs, no example database written to disk); ``SLOW`` is the 10 000-case variant (``-m slow``).
"""
import os
import tempfile

from hypothesis import HealthCheck, settings

FAST = settings(max_examples=150, derandomize=True, deadline=5000, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
SLOW = settings(FAST, max_examples=10_000)


def read_mutated(data: bytes, name: str, read, error: type):
    """Write ``data`` as ``name`` in a fresh folder and ``read(path)`` it: the result, or None
    when it raised ``error`` with a one-line message. Any other exception propagates (the fuzz
    finding); so does a file left beside the input."""
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, name)
        with open(path, "wb") as fh:
            fh.write(data)
        try:
            result = read(path)
        except error as exc:
            assert str(exc) and "\n" not in str(exc), repr(exc)
            result = None
        assert os.listdir(folder) == [name], os.listdir(folder)
    return result
