"""Engineering values next to raw words (``decode --icd``, ``monitor --icd``)."""
