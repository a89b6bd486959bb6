"""Measurement formats, read and written: hertzsweep's CSV (``measured``), UFF 58/58b
(``uff``), lock-in tables (``lockin_table``), the options that turn a file's numbers into
N/F_s (``import_options``) and the reader of any of them (``formats``). Above ``output``
(they build and read its datasets), below the orchestration and the API."""
