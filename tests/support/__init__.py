"""Code the tests and the benches share that the product does not use.

* :mod:`.assembler_reference`: the 1553 message grammar in plain Python, the reference the
  compiled assembler is tested against;
* :mod:`.corruption`: damaged words of every kind, for the word-integrity campaign.

Imported as ``tests.support.<module>``: from the tests (run from the repository root) and
from ``bench/`` scripts, which put the repository root on ``sys.path``.
"""
