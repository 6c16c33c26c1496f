"""The README's Python example runs and prints what it says."""
import re
from pathlib import Path

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_example(capsys):
    code = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    exec(compile(code, "README.md", "exec"), {})
    before, after = map(float, capsys.readouterr().out.split())
    assert abs(before - 0.5) < 1e-12
    assert abs(after - 1.0) < 1e-12
