"""SSP features against hand-computed values: nested systems, transformations, units, parameter sources,
settings annotations of other tools, and the three ways of naming a scenario."""
from pathlib import Path

import numpy as np
import pytest

import master
from master.inspect_scenario import inspect

from ssd_text import (component, connection, connector, experiment, inline_params, real_param, settings, ssd,
                       write_folder, zip_folder, SSV, SSM)

UNITS = ('<ssd:Units><ssc:Unit name="km"><ssc:BaseUnit m="1" factor="1000"/></ssc:Unit>'
         '<ssc:Unit name="m"><ssc:BaseUnit m="1"/></ssc:Unit>'
         '<ssc:Unit name="s"><ssc:BaseUnit s="1"/></ssc:Unit></ssd:Units>\n')


def _chain(src_unit=None, g_unit=None, link_inner="", link_attrs="", g_bindings="", sub_bindings="",
           top_extra="", exp=None):
    """src (Integrator, constant y = x0 = 1) -> sub{ g (Gain) } -> sink (Integrator)."""
    src = component("src", "resources/Integrator.fmu",
                    connector("y", "output", unit=src_unit),
                    inline_params(real_param("x0", 1.0)))
    g = component("g", "resources/Gain.fmu", connector("u", "input", unit=g_unit) + connector("y", "output"),
                  g_bindings)
    sub = (f'<ssd:System name="sub"><ssd:Connectors>{connector("in", "input", unit=g_unit)}'
           f'{connector("out", "output")}</ssd:Connectors>{sub_bindings}<ssd:Elements>{g}</ssd:Elements>'
           f'<ssd:Connections>{connection(None, "in", "g", "u")}{connection("g", "y", None, "out")}'
           '</ssd:Connections></ssd:System>\n')
    sink = component("sink", "resources/Integrator.fmu", connector("u", "input") + connector("y", "output"))
    conns = connection("src", "y", "sub", "in", link_inner, link_attrs) + connection("sub", "out", "sink", "u")
    return ssd("chain", src + sub + sink, conns, top_extra=top_extra,
               experiment_xml=exp if exp is not None else experiment(1.0, settings(0.1)))


@pytest.fixture
def chain_fmus(test_fmus):
    return {"Integrator.fmu": test_fmus["c2:Integrator"], "Gain.fmu": test_fmus["c2:Gain"]}


def _run(folder, **kw):
    kw.setdefault("output", None)
    kw.setdefault("record", ["*"])
    return master.run(folder, **kw)


def test_nested_system_and_linear_transformation(tmp_path, chain_fmus):
    # g.u = 3 * src.y + 1 = 4 (LinearTransformation), g.y = k u with default k = 1, sink integrates 4
    xml = _chain(link_inner='<ssc:LinearTransformation factor="3" offset="1"/>')
    r = _run(write_folder(tmp_path / "s", xml, chain_fmus))
    df = r.frame
    assert list(df.columns[:1]) == ["time"]
    assert np.all(df["sub.g.u"] == 4.0)
    np.testing.assert_allclose(df["sink.y"], 4.0 * df["time"], rtol=0, atol=1e-14)
    assert len(df) == 11 and df["time"].iloc[-1] == 1.0


def test_unit_conversion_then_linear_transformation(tmp_path, chain_fmus):
    # 1 km -> 1000 m, then the SSP order: factor * converted + offset = 2 * 1000 + 5
    xml = _chain("km", "m", link_inner='<ssc:LinearTransformation factor="2" offset="5"/>', top_extra=UNITS)
    r = _run(write_folder(tmp_path / "s", xml, chain_fmus))
    assert np.all(r.frame["sub.g.u"] == 2005.0)


def test_suppress_unit_conversion(tmp_path, chain_fmus):
    xml = _chain("km", "m", link_attrs=' suppressUnitConversion="true"', top_extra=UNITS)
    r = _run(write_folder(tmp_path / "s", xml, chain_fmus))
    assert np.all(r.frame["sub.g.u"] == 1.0)


def test_incompatible_units_are_an_error(tmp_path, chain_fmus):
    xml = _chain("km", "s", top_extra=UNITS)
    with pytest.raises(master.ScenarioError, match="units km and s are not convertible"):
        _run(write_folder(tmp_path / "s", xml, chain_fmus))


def test_ssv_with_prefix_and_ssm_mapping(tmp_path, chain_fmus):
    # a system-level binding on 'sub' with prefix 'g.' applies the bare name 'gain' (mapped to 'k' by the .ssm)
    binding = ('<ssd:ParameterBindings><ssd:ParameterBinding source="resources/sub.ssv" prefix="g.">'
               '<ssd:ParameterMapping source="resources/sub.ssm"/></ssd:ParameterBinding></ssd:ParameterBindings>')
    ssv = SSV.format(params=real_param("gain", 7.0))
    ssm = SSM.format(entries='<ssm:MappingEntry source="g.gain" target="g.k">'
                             '<ssc:LinearTransformation factor="2" offset="0"/></ssm:MappingEntry>\n')
    xml = _chain(sub_bindings=binding)
    folder = write_folder(tmp_path / "s", xml, chain_fmus, {"resources/sub.ssv": ssv, "resources/sub.ssm": ssm})
    r = _run(folder)
    # k = 2 * 7 = 14 (mapping transformation), g.y = 14 * 1
    assert np.all(r.frame["sub.g.y"] == 14.0)
    info = inspect(folder)
    assert {"variable": "sub.g.k", "value": 14.0} .items() <= {k: v for p in info["parameters"]
                                                               for k, v in p.items() if p["variable"] == "sub.g.k"}.items()


def test_component_ssv_binding_and_command_line_override(tmp_path, chain_fmus):
    binding = ('<ssd:ParameterBindings><ssd:ParameterBinding source="resources/g.ssv"/></ssd:ParameterBindings>')
    xml = _chain(g_bindings=binding)
    folder = write_folder(tmp_path / "s", xml, chain_fmus, {"resources/g.ssv": SSV.format(params=real_param("k", 5.0))})
    assert np.all(_run(folder).frame["sub.g.y"] == 5.0)
    assert np.all(_run(folder, params={"sub.g.k": "-2.5"}).frame["sub.g.y"] == -2.5)


@pytest.mark.parametrize("where,annotation,expected", [
    ("system", '<ssd:Annotations><ssc:Annotation type="org.openmodelica"><oms:Annotations><oms:SimulationInformation>'
               '<oms:FixedStepMaster description="oms-ma" stepSize="0.250000"/></oms:SimulationInformation>'
               '</oms:Annotations></ssc:Annotation></ssd:Annotations>', 0.25),
    ("experiment", '<ssd:Annotations><ssc:Annotation type="com.opensimulationplatform"><osp:Algorithm>'
                   '<osp:FixedStepAlgorithm baseStepSize="0.125"/></osp:Algorithm></ssc:Annotation></ssd:Annotations>',
     0.125),
])
def test_step_size_from_other_tools_annotations(tmp_path, chain_fmus, where, annotation, expected):
    xml = _chain(exp=experiment(1.0, annotation if where == "experiment" else ""))
    if where == "system":
        xml = xml.replace('<ssd:System name="chain">\n', f'<ssd:System name="chain">\n', 1)
        # system annotations come last inside ssd:System
        xml = xml.replace("</ssd:Connections>\n</ssd:System>", f"</ssd:Connections>\n{annotation}</ssd:System>", 1)
    folder = write_folder(tmp_path / "s", xml, chain_fmus)
    r = _run(folder)
    assert r.metadata["step_size"] == expected
    assert r.metadata["steps"] == round(1.0 / expected)
    assert _run(folder, step=0.5).metadata["steps"] == 2    # the command line wins


def test_folder_archive_and_bare_ssd_agree(tmp_path, chain_fmus):
    folder = write_folder(tmp_path / "s", _chain(link_inner='<ssc:LinearTransformation factor="3"/>'), chain_fmus)
    ssp = zip_folder(folder, tmp_path / "chain.ssp")
    a = _run(folder).frame
    b = _run(ssp).frame
    c = _run(folder / "SystemStructure.ssd").frame
    assert a.equals(b) and a.equals(c)


def test_inspect_reports_structure_and_settings(tmp_path, chain_fmus):
    folder = write_folder(tmp_path / "s", _chain(link_inner='<ssc:LinearTransformation factor="3" offset="1"/>'),
                          chain_fmus)
    info = inspect(folder)
    assert set(info["components"]) == {"src", "sub.g", "sink"}
    assert info["components"]["sub.g"]["fmi_version"] == "2.0"
    assert info["components"]["sub.g"]["kind"] == "CoSimulation"
    conns = {(c["from"], c["to"]): c for c in info["connections"]}
    assert conns[("src.y", "sub.g.u")]["factor"] == 3.0 and conns[("src.y", "sub.g.u")]["offset"] == 1.0
    assert ("sub.g.y", "sink.u") in conns
    assert info["settings"]["step_size"] == 0.1 and info["settings"]["steps"] == 10
    assert info["gauss_seidel_order"] == ["src", "sub.g", "sink"]


def test_ssp_2_0_document_is_read(tmp_path, chain_fmus):
    # SSP 2.0 keeps the SSP1 namespaces; no 2.0 schema ships with fmpy, so the document is parsed unvalidated
    xml = _chain(link_inner='<ssc:LinearTransformation factor="3" offset="1"/>').replace('version="1.0" name="chain"',
                                                                                          'version="2.0" name="chain"')
    r = _run(write_folder(tmp_path / "s", xml, chain_fmus))
    assert np.all(r.frame["sub.g.u"] == 4.0)


def test_each_fmu_is_unpacked_once_for_all_its_instances(tmp_path, chain_fmus, monkeypatch):
    import zipfile
    from master.fmi import cache
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(cache, "_by_hash", {})
    monkeypatch.setattr(cache, "_by_stat", {})
    opened = []
    real = zipfile.ZipFile.extractall

    def counting(self, *a, **k):
        opened.append(self.filename)
        return real(self, *a, **k)
    monkeypatch.setattr(zipfile.ZipFile, "extractall", counting)
    folder = write_folder(tmp_path / "s", _chain(), chain_fmus)   # src and sink share Integrator.fmu
    _run(folder)
    _run(folder)
    fmu_extractions = [f for f in opened if str(f).endswith(".fmu")]
    assert sorted(Path(f).name for f in fmu_extractions) == ["Gain.fmu", "Integrator.fmu"]
    # the unpacked FMUs, one folder per SHA-256 (beside them: the validation records, built C sources ...)
    assert len([p for p in (tmp_path / "cache").iterdir() if len(p.name) == 64]) == 2


def _ball(tmp_path, reference_fmus, units_xml, name):
    ball = component("ball", "resources/BouncingBall.fmu", connector("h", "output"),
                     inline_params(real_param("g", -32.17404855643, unit="ft/s2")))
    xml = ssd(name, ball, "", top_extra=units_xml, experiment_xml=experiment(0.4, settings(0.01)))
    return write_folder(tmp_path / name, xml, {"BouncingBall.fmu": reference_fmus / "fmi2" / "BouncingBall.fmu"})


def test_parameter_in_a_unit_without_definition_is_an_error(tmp_path, reference_fmus):
    # the FMU declares g in m/s2; 'ft/s2' is defined nowhere, so the value cannot be converted (it used to be
    # passed through unconverted, i.e. 3.3 times too strong)
    with pytest.raises(master.ScenarioError, match="unit ft/s2 has no definition"):
        _run(_ball(tmp_path, reference_fmus, "", "nodef"))


def test_parameter_value_is_converted_to_the_fmu_unit(tmp_path, reference_fmus):
    units = '<ssd:Units><ssc:Unit name="ft/s2"><ssc:BaseUnit m="1" s="-2" factor="0.3048"/></ssc:Unit></ssd:Units>\n'
    df = _run(_ball(tmp_path, reference_fmus, units, "conv"), record=["ball.h"]).frame
    g = -32.17404855643 * 0.3048            # = -9.80665 m/s2
    t = df["time"].to_numpy()
    before_bounce = t <= 0.4
    np.testing.assert_allclose(df["ball.h"][before_bounce], 1 + 0.5 * g * t[before_bounce] ** 2, atol=2e-3)


def test_an_ssp_we_write_for_an_fmu_with_an_enumeration_runs(tmp_path, reference_fmus):
    # the writer declares an FMU enumeration as an ssc:Integer connector; the parser refused that pairing,
    # so cosim-master rejected an SSP it wrote (the FMI 2.0 Reference FMU Feedthrough has Enumeration_input)
    from master.ssp.writer import SspBuilder
    b = SspBuilder("ft", stop=0.5, step=0.1)
    b.add_component("m", reference_fmus / "fmi2" / "Feedthrough.fmu")
    r = master.run(b.write(tmp_path / "ft.ssp"), output=None, params={"m.Enumeration_input": 2},
                   record=["m.Enumeration_output"])
    assert (r.frame["m.Enumeration_output"] == 2).all()
