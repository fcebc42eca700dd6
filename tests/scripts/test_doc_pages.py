"""The first pages a user reads say what they need (issue 46 item 7): the
README opens with what the tool does and its two set-up commands, then the
tour, the figures later; docs/python.md names every package its walkthrough
imports beyond the module's own, with the line that installs it, and
scripts/setup can install it; docs/api.md shows the query whose output it
prints. Reads the pages only: needs neither the module nor the data."""
import os
import re

SOURCE_DIR = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def page(name):
    with open(os.path.join(SOURCE_DIR, name), encoding="utf-8") as f:
        return f.read()


def test_readme_opens_with_what_it_does_then_the_two_setup_commands():
    text = page("README.md")
    head = text.split("\n## ", 1)[0]
    paragraphs = [p for p in head.split("\n\n")[1:] if p.strip()]
    assert not paragraphs[0].startswith("    "), "a sentence on what the tool does comes first"
    commands = [line.split("#")[0].strip() for line in head.splitlines()
                if line.startswith("    ")]
    assert commands == ["scripts/demo", "scripts/test"], commands


def test_readme_tours_before_its_figures():
    sections = re.findall(r"^## (.+)$", page("README.md"), re.M)
    assert sections[0] == "A short tour", sections
    assert sections.index("A short tour") < sections.index("Headline figures")


def walkthrough_imports():
    code = "\n".join(re.findall(r"```python\n(.*?)```", page("docs/python.md"), re.S))
    names = re.findall(r"^\s*(?:import|from)\s+([A-Za-z_]\w*)", code, re.M)
    return set(names) - {"mocap", "numpy", "os", "sys", "json", "pathlib"}


def test_the_python_walkthrough_names_its_optional_packages():
    text = page("docs/python.md")
    setup_section = text.split("## Build, import, install", 1)[1].split("\n## ", 1)[0]
    setup = page("scripts/setup")
    extras = walkthrough_imports()
    assert "matplotlib" in extras
    for name in extras:
        package = f"python3-{name}"
        assert package in setup_section, f"docs/python.md's set-up does not name {package}"
        assert f"apt-get install {package}" in setup_section
        assert package in setup, f"scripts/setup cannot install {package}"


def test_the_api_example_shows_the_query_it_runs():
    text = page("docs/api.md")
    example = text.split("## Searching an index from C++", 1)[1].split("\n## ", 1)[0]
    shown = re.search(r"\$ cat walk\.json.*\n\s*(\{.*\})\n", example)
    assert shown, "docs/api.md does not show walk.json"
    assert '"relative": false' in shown.group(1)
    assert re.search(r"\$ best_match three\.h5 walk\.json", example)
