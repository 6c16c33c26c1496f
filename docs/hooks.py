"""MkDocs hooks: the C++ API page is generated from the headers at every build, so
it cannot drift from them and nothing generated is committed."""
import importlib.util
from pathlib import Path

from mkdocs.structure.files import File

_HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("gen_cpp_api", _HERE / "gen_cpp_api.py")
gen_cpp_api = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(gen_cpp_api)

CPP_PAGE = "reference/cpp.md"


def on_files(files, config):
    files.append(File.generated(config, CPP_PAGE, content=gen_cpp_api.render()))
    return files


def on_config(config):
    # mkdocs serve: rebuild when a header changes
    config.watch.append(str(_HERE.parent / "cpp" / "include"))
    return config
