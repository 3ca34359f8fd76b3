"""Engineering values next to raw words (``decode --icd``, ``monitor --icd``).

* :mod:`.view`: :class:`~.view.IcdView`, one record's values (loads the table only when given);
* :mod:`.batch`: a whole Chapter 10 batch's values as JSON text, column by column;
* :mod:`.numbers`: numbers as ``json.dumps`` writes them, a column at a time;
* :mod:`.rows` and :mod:`.jsontext`: the compiled writer of a batch's text.

Nothing is imported here, so a plain ``mapr decode`` pays for none of it.
"""
