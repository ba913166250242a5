"""One module per ``topomap`` command, each with ``add_parser(sub)`` (its options) and its
``cmd_*`` handlers; :mod:`topomap.cli.main` builds the parser from them. What they share
(option types, input readers, output checks) is :mod:`topomap.cli.commands.common`."""
