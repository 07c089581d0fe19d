"""The shortcuts of a run's start (Execution.initialize), each of which must leave what a run does unchanged: start
values set in one update per slave and type (``Slave.values_setter``), in-process ports without ctypes pointers,
and what one run leaves for the next in the same process (the step code shared by the runs of one structure)."""
from pathlib import Path


import master
from master.execution import Execution
from master.fmi.inprocess import PythonFmuSlave
from master.runtime import Runtime

ROOT = Path(__file__).resolve().parents[2]
ONE = ROOT / "ssp" / "paper_zones_1uav_A.ssp"
FOUR = ROOT / "ssp" / "paper_zones_4uav_B.ssp"
KW = dict(stop_time=40.0, step=0.5, record=["*"], record_interval=0.5)


def _run(ssp, folder, **kw):
    # a campaign worker's run: into a folder, its mission's summary files only (products="summary")
    return master.run(ssp, output=folder, products="summary", **{**KW, **kw}).frame


def _variable_values(obj) -> dict:
    """An in-process instance's plain attributes, each as (type, repr): repr tells every float bit (-0.0 too)."""
    return {k: (type(v).__name__, repr(v)) for k, v in vars(obj).items()
            if type(v) in (float, int, bool, str)}


def _after_start_values(monkeypatch, batched: bool, params: dict):
    """Every component's attributes right after the start values were applied, and the run's recorded frame."""
    seen = {}
    apply = Runtime.apply_start_values

    def spy(rt, start):
        apply(rt, start)
        seen.update({name: _variable_values(s.obj) for name, s in zip(rt.names, rt.slaves)})
    monkeypatch.setattr(Runtime, "apply_start_values", spy)
    if not batched:
        monkeypatch.setattr(PythonFmuSlave, "values_setter", lambda self, typ, vrs: None)
    with Execution(FOUR, output=None, params=params, **KW) as ex:
        ex.simulate_until()
        frame = ex.memory_table().to_pandas()
    monkeypatch.undo()
    return seen, frame


def test_start_values_in_one_update_equal_one_by_one(monkeypatch):
    # values of every base type, some given in another Python type than the variable's (converted as set_<type>
    # converts them), beside the SSD's own parameters
    params = {"uav1_dyn.mass": 2, "uav1_strat.zone_planning": 0, "uav2_strat.uav_index": 1.0,
              "uav1_bat.initial_soc": 0.75, "uav1_strat.strategy": "B", "uav3_dyn.speed": -0.0}
    one_by_one, frame_a = _after_start_values(monkeypatch, batched=False, params=params)
    batched, frame_b = _after_start_values(monkeypatch, batched=True, params=params)
    assert batched.keys() == one_by_one.keys() and len(batched) == 13
    for name in batched:
        assert batched[name] == one_by_one[name], name
    assert batched["uav1_dyn"]["mass"] == ("float", "2.0")
    assert batched["uav1_strat"]["zone_planning"] == ("bool", "False")
    assert batched["uav3_dyn"]["speed"] == ("float", "-0.0")
    assert frame_a.equals(frame_b)


def test_a_batch_the_shell_cannot_take_is_set_one_by_one():
    # a value reference without a plain attribute (here: one that does not exist) gets no setter; one with it stores
    # the converted values in order (the later of two values of one variable wins)
    ex = Execution(FOUR, output=None, **KW)
    try:
        ex.initialize()
        slave = ex.rt.slaves[ex.rt.index["uav1_dyn"]]
        assert slave.values_setter("Real", [10 ** 6]) is None
        mass = ex.prepared.plan.variables["uav1_dyn"]["mass"]
        assert slave.values_setter("Real", [mass.vr, mass.vr])([3, 4.5]) is True
        assert slave.obj.mass == 4.5 and type(slave.obj.mass) is float
        assert slave.values_setter("Real", [mass.vr])([2]) is True and repr(slave.obj.mass) == "2.0"
    finally:
        ex.close()


def test_a_slave_with_a_declined_type_gets_all_its_values_one_by_one(monkeypatch):
    # its Integer values have no setter: its Real values go one by one too, in the plan's order, with the others'
    calls = []
    orig_setter, orig_value = PythonFmuSlave.values_setter, PythonFmuSlave.set_value

    def setter(self, typ, vrs):
        return None if (self.name == "uav1_strat" and typ == "Integer") else orig_setter(self, typ, vrs)

    def set_value(self, typ, vr, value):
        calls.append((self.name, typ))
        return orig_value(self, typ, vr, value)
    monkeypatch.setattr(PythonFmuSlave, "values_setter", setter)
    monkeypatch.setattr(PythonFmuSlave, "set_value", set_value)
    ex = Execution(FOUR, output=None, **KW)
    try:
        ex.initialize()
    finally:
        ex.close()
    mine = [q for q in ex.prepared.plan.params if q[0].component == "uav1_strat"]
    assert calls == [("uav1_strat", v.type) for v, _, _ in mine]
    assert {t for _, t in calls} >= {"Integer", "Real", "String"}


def test_in_process_ports_have_no_ctypes_pointers():
    ex = Execution(FOUR, output=None, **KW)
    try:
        ex.initialize()
        ports = [p for ports in ex.rt.read_ports + ex.rt.write_ports for _, p in ports]
        assert ports and all(p.vr_ptr is None and p.buf_ptr is None for p in ports)
    finally:
        ex.close()


def test_runs_one_after_another_in_one_process_equal_a_first_run(tmp_path):
    # what a campaign worker does: caches warm from the earlier runs must not change a later one. Each scenario
    # runs first, then again after the other one has run (ONE, FOUR, ONE, FOUR: four runs where two separate
    # tests of ONE-FOUR-ONE and FOUR-ONE-FOUR took six)
    first_one = _run(ONE, tmp_path / "a")
    first_four = _run(FOUR, tmp_path / "b")
    assert _run(ONE, tmp_path / "c").equals(first_one)
    assert _run(FOUR, tmp_path / "d").equals(first_four)
