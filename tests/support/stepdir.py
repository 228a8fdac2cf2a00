"""The seed machine with step/dir drivers (test_stepdir.py, test_preview_simulate.py)."""

STEPDIR = """
driver = "stepdir"
left_step_pin = 17
left_dir_pin = 27
right_step_pin = 22
right_dir_pin = 23
enable_pin = 4
"""


def stepdir_toml(config_path) -> str:
    """The seed config with step/dir drivers instead of ULN2003 boards (left_reverse kept)."""
    text = config_path.read_text(encoding="utf-8")
    out = []
    for line in text.splitlines():
        if line.startswith(("left_pins", "right_pins", "drive ")):
            continue
        out.append(line)
        if line.strip() == "[motors]":
            out.append(STEPDIR.strip())
    return "\n".join(out) + "\n"
