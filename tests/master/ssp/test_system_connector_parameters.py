"""Parameter values given to connectors of systems, connections without startElement/endElement, values that
name nothing, a mapping source with several targets: each against the value worked out from the SSD by hand.

The system: src (Integrator, y = x0, no input) -> sub{ g (Gain, y = k u) } -> sink; the top system and ``sub``
have parameter connectors (``kk``, ``kin``) connected down to ``g.k``, so g.y = g.k * 1 shows the k a run took.
"""
import logging

import numpy as np
import pytest

import master

from ssd_text import SSM, SSV, component, connection, connector, experiment, inline_params, real_param, settings, \
    ssd, write_folder


@pytest.fixture
def chain_fmus(test_fmus):
    return {"Integrator.fmu": test_fmus["c2:Integrator"], "Gain.fmu": test_fmus["c2:Gain"]}


def _system(top_bindings="", sub_bindings="", g_bindings="", kk_link="", kin_link="", start_attr=None):
    """``kk`` (top) -> ``sub.kin`` -> ``g.k``, with transformations ``kk_link`` / ``kin_link``; ``start_attr``:
    write the connection from ``kin`` with ``startElement=""`` (OMSimulator's way) instead of leaving it out."""
    src = component("src", "resources/Integrator.fmu", connector("y", "output"), inline_params(real_param("x0", 1.0)))
    g = component("g", "resources/Gain.fmu",
                  connector("u", "input") + connector("y", "output") + connector("k", "parameter"), g_bindings)
    if start_attr is None:
        kin_to_k = connection(None, "kin", "g", "k", kin_link)
    else:
        kin_to_k = f'<ssd:Connection startElement="" startConnector="kin" endElement="g" endConnector="k">{kin_link}' \
                   '</ssd:Connection>\n'
    sub = (f'<ssd:System name="sub"><ssd:Connectors>{connector("in", "input")}{connector("out", "output")}'
           f'{connector("kin", "parameter")}</ssd:Connectors>{sub_bindings}<ssd:Elements>{g}</ssd:Elements>'
           f'<ssd:Connections>{connection(None, "in", "g", "u")}{connection("g", "y", None, "out")}{kin_to_k}'
           '</ssd:Connections></ssd:System>\n')
    sink = component("sink", "resources/Integrator.fmu", connector("u", "input") + connector("y", "output"))
    conns = (connection("src", "y", "sub", "in") + connection("sub", "out", "sink", "u")
             + connection(None, "kk", "sub", "kin", kk_link))
    top = f'<ssd:Connectors>{connector("kk", "parameter")}</ssd:Connectors>{top_bindings}'
    return ssd("chain", src + sub + sink, conns, system_extra=top, experiment_xml=experiment(1.0, settings(0.5)))


def _gain(tmp_path, chain_fmus, extra=None, **kw) -> float:
    """The gain g.y / g.u the run took (g.u = src.y = 1)."""
    df = master.run(write_folder(tmp_path / "s", _system(**kw), chain_fmus, extra), output=None,
                    record=["*"]).frame
    assert np.all(df["sub.g.u"] == 1.0)
    assert df["sub.g.y"].nunique() == 1
    return df["sub.g.y"].iloc[0]


def _binding(params: str) -> str:
    return inline_params(params)


def test_a_top_level_connector_value_reaches_the_component_through_a_subsystem(tmp_path, chain_fmus):
    # kk = 3 at the top system -> (factor 2, offset 1) -> sub.kin -> (factor 10) -> g.k = 10 * (2 * 3 + 1) = 70
    k = _gain(tmp_path, chain_fmus, top_bindings=_binding(real_param("kk", 3.0)),
              kk_link='<ssc:LinearTransformation factor="2" offset="1"/>',
              kin_link='<ssc:LinearTransformation factor="10" offset="0"/>')
    assert k == 70.0


def test_a_subsystem_binds_its_own_connector_and_an_enclosing_system_names_it(tmp_path, chain_fmus):
    # at sub: kin = 5 -> g.k = 5; at the top, the hierarchical name sub.kin = 4 (SSP 1.0 5.3.3: the higher
    # level takes precedence) -> g.k = 4
    assert _gain(tmp_path, chain_fmus, sub_bindings=_binding(real_param("kin", 5.0))) == 5.0
    assert _gain(tmp_path, chain_fmus, sub_bindings=_binding(real_param("kin", 5.0)),
                 top_bindings=_binding(real_param("sub.kin", 4.0))) == 4.0


def test_an_empty_start_element_is_a_connector_of_the_system(tmp_path, chain_fmus):
    assert _gain(tmp_path, chain_fmus, sub_bindings=_binding(real_param("kin", 6.0)), start_attr="") == 6.0


def test_precedence_between_levels_and_within_a_binding(tmp_path, chain_fmus):
    # the component's own k = 2; the system's direct sub.g.k = 7 wins (higher level)
    g_k = _binding(real_param("k", 2.0))
    assert _gain(tmp_path, chain_fmus, g_bindings=g_k) == 2.0
    assert _gain(tmp_path, chain_fmus, g_bindings=g_k, top_bindings=_binding(real_param("sub.g.k", 7.0))) == 7.0
    # in one binding, a value through a connected connector (kk = 3 -> k = 3) wins over a direct one (as in
    # OMSimulator: tests/interop/test_omsimulator_testsuite.py, import_export_parameters1)
    both = real_param("kk", 3.0) + real_param("sub.g.k", 7.0)
    assert _gain(tmp_path, chain_fmus, g_bindings=g_k, top_bindings=_binding(both)) == 3.0


def test_values_that_name_nothing_are_ignored_with_one_warning_per_file(tmp_path, chain_fmus, caplog):
    # SSP 1.0 5.3.3: names of a parameter source "... are ignored if no matching variable is found"
    params = (real_param("kk", 3.0) + real_param("no.such.element", 1.0) + real_param("sub.nothing", 2.0)
              + real_param("sub.g.kx", 4.0))
    binding = '<ssd:ParameterBindings><ssd:ParameterBinding source="resources/top.ssv"/></ssd:ParameterBindings>'
    with caplog.at_level(logging.WARNING, logger="cosim_master"):
        k = _gain(tmp_path, chain_fmus, {"resources/top.ssv": SSV.format(params=params)}, top_bindings=binding)
    assert k == 3.0
    warned = [r.getMessage() for r in caplog.records if "ignoring" in r.getMessage()]
    assert len(warned) == 1
    assert warned[0].endswith("resources/top.ssv: ignoring 3 parameter values that name no connector or variable "
                              "of the system (SSP: ignored): no.such.element, sub.nothing, sub.g.kx")


def test_one_mapping_source_with_two_targets(tmp_path, chain_fmus):
    # 'gain' = 2 goes to sub.g.k (x 3) and to src.x0 (+ 1): g.u = x0 = 3, g.y = 6 * 3 = 18
    ssm = SSM.format(entries='<ssm:MappingEntry source="gain" target="sub.g.k"><ssc:LinearTransformation factor="3"/>'
                             '</ssm:MappingEntry>\n<ssm:MappingEntry source="gain" target="src.x0">'
                             '<ssc:LinearTransformation factor="1" offset="1"/></ssm:MappingEntry>\n')
    binding = ('<ssd:ParameterBindings><ssd:ParameterBinding source="resources/top.ssv">'
               '<ssd:ParameterMapping source="resources/top.ssm"/></ssd:ParameterBinding></ssd:ParameterBindings>')
    folder = write_folder(tmp_path / "s", _system(top_bindings=binding), chain_fmus,
                          {"resources/top.ssv": SSV.format(params=real_param("gain", 2.0)), "resources/top.ssm": ssm})
    df = master.run(folder, output=None, record=["*"]).frame
    assert np.all(df["sub.g.u"] == 3.0) and np.all(df["sub.g.y"] == 18.0)


def test_the_enclosing_systems_settings_annotation_wins_over_a_subsystems(tmp_path, chain_fmus):
    # OMSimulator writes its annotation on subsystems too (import_export_parameters1: a variable-step solver on
    # an empty subsystem, the fixed step on the top system); the top system's step size is the run's
    oms = ('<ssd:Annotations><ssc:Annotation type="org.openmodelica"><oms:Annotations><oms:SimulationInformation>'
           '{}</oms:SimulationInformation></oms:Annotations></ssc:Annotation></ssd:Annotations>')
    xml = _system().replace("</ssd:Connections></ssd:System>", "</ssd:Connections>" + oms.format(
        '<oms:VariableStepSolver description="cvode" initialStepSize="0.0001"/>') + "</ssd:System>", 1)
    xml = xml.replace("</ssd:Connections>\n</ssd:System>", "</ssd:Connections>\n" + oms.format(
        '<oms:FixedStepMaster description="oms-ma" stepSize="0.25"/>') + "</ssd:System>", 1)
    xml = xml.replace(settings(0.5), "")
    r = master.run(write_folder(tmp_path / "s", xml, chain_fmus), output=None, record=["*"])
    assert r.frame["time"].tolist() == [0.0, 0.25, 0.5, 0.75, 1.0]


def test_a_structure_read_again_gives_its_connector_values_alike(tmp_path, chain_fmus):
    # a campaign reads the same structure run after run (parser.read_ssd(reuse_structure=True)): the second read
    # takes the connectors and paths from the kept structure
    from master.ssp.parser import read_ssd
    xml = _system(top_bindings=_binding(real_param("kk", 3.0) + real_param("nothing", 1.0)),
                  kk_link='<ssc:LinearTransformation factor="2" offset="1"/>')
    folder = write_folder(tmp_path / "s", xml, chain_fmus)
    reads = [read_ssd(folder / "SystemStructure.ssd", folder, reuse_structure=True) for _ in range(2)]
    assert reads[1].structure == reads[0].structure is not None
    for m in reads:
        assert [(p.component, p.variable, p.value) for p in m.parameters if p.component == "sub.g"] == [
            ("sub.g", "k", 7.0)]
        assert [name for _, name in m.ignored_parameters] == ["nothing"]
