"""Studies: measurements of the package against the plants, each a report in ``docs/`` with
its command. Nothing here runs in a cell."""
