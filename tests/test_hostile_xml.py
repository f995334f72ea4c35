"""Hostile input, XML: a URDF with a document type declaration is refused, by every reader.

A DTD is where entities are declared, parameter entities (``<!ENTITY % ...>``) included, and
ElementTree expands internal ones: a file could grow far past its stated size while it is
parsed, or say something other than what it shows. A URDF needs no DTD, so both readers (a
puzzle folder's, :func:`phyrogen_core.export.read_puzzle_dir`, and the importer's) refuse any
with one line naming the file, before anything is built. Beside each refusal, the same file
without its DTD is accepted: the refusal is the DTD's, not the file's.
"""

from __future__ import annotations

import contextlib
import io

import pytest
from hostile_support import assert_cli_rejects, cli_check, copy_folder, urdf_file, written  # noqa: F401

from phyrogen.cli import main
from phyrogen_core.xml_fields import DoctypeError, parse_xml

PARAMETER_ENTITY = '<!DOCTYPE robot [<!ENTITY % inner "<!ENTITY hidden \'0.5\'>"> %inner;]>\n'
"""The reported case: a parameter entity that declares another entity."""
DOCTYPES = {
    "parameter entity": PARAMETER_ENTITY,
    "internal entity": '<!DOCTYPE robot [<!ENTITY size "1 1 1">]>\n',
    "nested entities": '<!DOCTYPE robot [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;">]>\n',
    "external subset": '<!DOCTYPE robot SYSTEM "robot.dtd">\n',
    "empty": "<!DOCTYPE robot>\n",
}


def with_doctype(text: str, doctype: str) -> str:
    """``text`` with ``doctype`` after its XML declaration (or first, without one)."""
    if text.startswith("<?xml"):
        end = text.index("?>") + 2
        return text[:end] + "\n" + doctype + text[end:].lstrip("\n")
    return doctype + text


@pytest.mark.parametrize("doctype", DOCTYPES.values(), ids=DOCTYPES.keys())
def test_check_refuses_a_urdf_with_a_dtd(doctype, written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "puzzle")
    urdf = urdf_file(folder)
    urdf.write_text(with_doctype(urdf.read_text(), doctype))
    assert_cli_rejects(folder, str(urdf), "document type declaration")


def test_the_same_urdf_without_the_dtd_passes_check(written, tmp_path):  # noqa: F811
    # The negative control: the refusal above comes from the DTD alone.
    folder = copy_folder(written, tmp_path / "puzzle")
    code, out, err = cli_check(folder)
    assert (code, err) == (0, ""), (code, out, err)
    assert "certificate valid" in out


def test_the_parameter_entity_used_in_an_attribute_is_refused_too(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "puzzle")
    urdf = urdf_file(folder)
    text = urdf.read_text()
    text = text.replace('<mass value="', '<mass value="&hidden;" data-was="', 1)
    assert "&hidden;" in text
    urdf.write_text(with_doctype(text, PARAMETER_ENTITY))
    assert_cli_rejects(folder, "document type declaration")


def test_import_refuses_a_urdf_with_a_dtd_before_any_work(tmp_path, monkeypatch):
    import solver.pipelines.importing

    def started(*args, **kwargs):
        raise AssertionError("certification started for a URDF that should have been refused")

    monkeypatch.setattr(solver.pipelines.importing, "certify_imported", started)
    text = ('<?xml version="1.0"?>\n<robot name="r"><link name="base_link"/><link name="goal"/>'
            '<joint name="g" type="fixed"><parent link="base_link"/><child link="goal"/></joint></robot>\n')
    plain, hostile = tmp_path / "plain.urdf", tmp_path / "hostile.urdf"
    plain.write_text(text)
    hostile.write_text(with_doctype(text, PARAMETER_ENTITY))
    outcomes = {}
    for path in (plain, hostile):
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            outcomes[path] = (main(["import", str(path), "--out", str(tmp_path / "out")]), err.getvalue())
    code, err = outcomes[hostile]
    assert code == 2 and err.count("\n") == 1 and str(hostile) in err and "document type declaration" in err, err
    # The control gets past the XML (and is refused later, for its lack of movable objects).
    code, err = outcomes[plain]
    assert code == 2 and "document type declaration" not in err, err
    assert not (tmp_path / "out" / "imported").exists()


@pytest.mark.parametrize("data", [
    "<robot/>", b"<robot/>", '<?xml version="1.0" encoding="UTF-8"?><!-- <!DOCTYPE x> --><robot/>',
    "<robot><![CDATA[<!DOCTYPE robot>]]></robot>",
])
def test_documents_without_a_dtd_parse(data):
    assert parse_xml(data).tag == "robot"


@pytest.mark.parametrize("data", [doctype + "<robot/>" for doctype in DOCTYPES.values()]
                         + [('<?xml version="1.0" encoding="UTF-16"?>' + PARAMETER_ENTITY + "<robot/>")
                            .encode("utf-16")])
def test_documents_with_a_dtd_raise(data):
    with pytest.raises(DoctypeError):
        parse_xml(data)
