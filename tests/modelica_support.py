"""Small Modelica packages written by the compiler tests: the model text of a test stands in the test."""

import textwrap


def write_package(folder, body):
    """``folder/T.mo`` holding ``package T`` around ``body`` (dedented; its first line is line 2 of the file)."""
    path = folder / "T.mo"
    path.write_text("package T\n" + textwrap.dedent(body).strip("\n") + "\nend T;\n")
    return path
