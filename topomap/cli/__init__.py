"""The tools around the library: the ``topomap`` command line (:mod:`topomap.cli.main`, one
module per command in :mod:`topomap.cli.commands`), the demo, benchmarks, evaluations and
pictures. Nothing in the library packages imports from here."""
