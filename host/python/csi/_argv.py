"""Command-line checks shared by csi's Python programs (csi-mitsuba, csi-farm)."""


def unknown_option(parsers, argv):
    """The first word of argv that looks like a long option and is none of the parsers' options
    (nor an abbreviation of one, as argparse takes them), or None. argparse names a missing
    positional argument first when a misspelt option is the only word; the programs name the
    option instead."""
    known = [k for p in parsers for k in p._option_string_actions]
    for word in argv:
        name = word.split("=", 1)[0]
        if word.startswith("--") and len(word) > 2 and not any(k.startswith(name) for k in known):
            return word
    return None
