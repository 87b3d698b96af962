"""The command line: decks (read by the core's reader, run case by case),
campaigns of many decks side by side, and the ``mlid`` command."""
