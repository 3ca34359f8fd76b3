"""MIL-STD-1553B words, the Manchester-II codec and the message assembler."""
