"""Hand-written SSD documents for the tests, so that the parser is checked against XML we control."""
from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

HEAD = ('<?xml version="1.0" encoding="UTF-8"?>\n'
        '<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
        'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
        'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
        'xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping" '
        'xmlns:oms="https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd" '
        'xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations" '
        'xmlns:cm="https://cosim-master.org/ssp/settings" version="1.0" name="{name}">\n')
TAIL = "</ssd:SystemStructureDescription>\n"

SSV = ('<?xml version="1.0" encoding="UTF-8"?>\n'
       '<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
       'version="1.0" name="set">\n<ssv:Parameters>\n{params}</ssv:Parameters>\n</ssv:ParameterSet>\n')
SSM = ('<?xml version="1.0" encoding="UTF-8"?>\n'
       '<ssm:ParameterMapping xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping" '
       'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0">\n{entries}'
       '</ssm:ParameterMapping>\n')


def real_param(name, value, unit=None):
    u = f' unit="{unit}"' if unit else ""
    return f'<ssv:Parameter name="{name}"><ssv:Real value="{value!r}"{u}/></ssv:Parameter>\n'


def connector(name, kind, typ="Real", unit=None):
    u = f' unit="{unit}"' if unit else ""
    return f'<ssd:Connector name="{name}" kind="{kind}"><ssc:{typ}{u}/></ssd:Connector>\n'


def component(name, source, connectors="", bindings=""):
    return (f'<ssd:Component name="{name}" type="application/x-fmu-sharedlibrary" source="{source}">\n'
            f'<ssd:Connectors>\n{connectors}</ssd:Connectors>\n{bindings}</ssd:Component>\n')


def inline_params(params: str):
    return ('<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>'
            f'<ssv:ParameterSet version="1.0" name="p"><ssv:Parameters>\n{params}</ssv:Parameters>'
            '</ssv:ParameterSet></ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>\n')


def connection(a, x, b, y, inner="", attrs=""):
    sa = f' startElement="{a}"' if a else ""
    eb = f' endElement="{b}"' if b else ""
    return f'<ssd:Connection{sa} startConnector="{x}"{eb} endConnector="{y}"{attrs}>{inner}</ssd:Connection>\n'


def settings(step, algorithm=None, extra=""):
    alg = f' algorithm="{algorithm}"' if algorithm else ""
    return ('<ssd:Annotations><ssc:Annotation type="org.cosim-master.settings">'
            f'<cm:Settings stepSize="{step!r}"{alg}>{extra}</cm:Settings></ssc:Annotation></ssd:Annotations>')


def experiment(stop, annotations="", start=0.0):
    return f'<ssd:DefaultExperiment startTime="{start!r}" stopTime="{stop!r}">{annotations}</ssd:DefaultExperiment>\n'


def ssd(name, elements, connections="", system_extra="", top_extra="", experiment_xml=""):
    body = (f'<ssd:System name="{name}">\n{system_extra}<ssd:Elements>\n{elements}</ssd:Elements>\n'
            + (f"<ssd:Connections>\n{connections}</ssd:Connections>\n" if connections else "")
            + "</ssd:System>\n")
    return HEAD.format(name=name) + body + top_extra + experiment_xml + TAIL


def write_folder(folder: Path, ssd_xml: str, fmus: dict[str, Path], extra: dict[str, str] | None = None) -> Path:
    """An unpacked SSP: SystemStructure.ssd plus resources/<name> for each FMU and extra text files."""
    if folder.exists():
        shutil.rmtree(folder)
    (folder / "resources").mkdir(parents=True)
    (folder / "SystemStructure.ssd").write_text(ssd_xml)
    for name, src in fmus.items():
        shutil.copyfile(src, folder / "resources" / name)
    for name, text in (extra or {}).items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    return folder


def zip_folder(folder: Path, ssp: Path) -> Path:
    with zipfile.ZipFile(ssp, "w") as zf:
        for p in sorted(folder.rglob("*")):
            if p.is_file():
                zf.write(p, p.relative_to(folder).as_posix())
    return ssp
