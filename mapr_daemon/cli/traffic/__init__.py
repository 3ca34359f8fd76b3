"""Bus traffic for the CLI: where records come from, which are kept, how they are written.

* :mod:`.source`: batches from a file or a live backend, and the statistics printed from them;
* :mod:`.decode_filter`: ``mapr decode``'s message filters;
* :mod:`.decode_text` and :mod:`.render`: one line per message, as text or JSON;
* :mod:`.chapter10_decode`: a Chapter 10 recording as JSON lines.

Nothing is imported here: each subcommand imports the module it needs when it runs.
"""
