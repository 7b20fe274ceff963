"""Help in the order a user reads it: csw --help lists the everyday commands first, and
csw match --help puts every option in a named section, from the output to the engine."""

from click.testing import CliRunner

from csw_cli.commands.match import MATCH_HELP, match
from csw_cli.main import FIRST, cli


def test_every_match_option_has_its_section_and_the_sections_read_in_order():
    placed = [name for _, names in MATCH_HELP.sections for name in names]
    assert len(placed) == len(set(placed))
    options = {p.name for p in match.params if p.param_type_name == "option"} - {"help"}
    assert options == set(placed)
    text = CliRunner().invoke(cli, ["match", "--help"]).output
    titles = [title for title, _ in MATCH_HELP.sections]
    where = [text.index(f"\n{title}:\n") for title in titles]
    assert where == sorted(where)
    assert text[text.index("Other options:"):].split()[2:4] == ["-h,", "--help"]
    assert titles[0] == "Output" and titles[1] == "Disparity range"
    options = text[text.index("\nOutput:\n"):]
    assert options.index("  --dmax") < options.index("  --preset") \
        < options.index("  --lr-check") < options.index("  --depth ") \
        < options.index("  --workers") < options.index("  --csw ") \
        < options.index("  --engine")
    # CSW, off by default, comes after depth and the rig (issue 39)
    assert options.index("  --rig") < options.index("  --csw ")


def test_csw_help_puts_the_everyday_commands_first():
    text = CliRunner().invoke(cli, ["--help"]).output
    first = text.index("Commands:")
    later = text.index("Benchmarks, experiments and set-up:")
    assert all(first < text.index(f"  {name} ") < later for name in FIRST)
    assert text.index("  bench ") > later
