"""Commands of the `harmony` command line that need more than a wrapper (registered in harmony_cli.cli)."""
