"""The README's "Use the runtime from Python" example runs as written."""
import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_the_runtime_example_runs(capsys):
    section = README.read_text().split("## Use the runtime from Python", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    exec(compile(code, "README.md", "exec"), {})
    assert "ms device" in capsys.readouterr().out
