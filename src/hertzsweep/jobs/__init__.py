"""Orchestration: what runs drivers and writes their datasets in several steps, the parts
of a study and their merge (``study``, ``realisations``), the paper's figures and table
(``paper``). Above ``output`` and ``io``, below the API."""
