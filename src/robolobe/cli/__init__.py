"""The ``robolobe`` command: parse, call, print; no logic lives here."""
