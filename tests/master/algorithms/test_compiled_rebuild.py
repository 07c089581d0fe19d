"""The compiled step rebuilt after components are taken out (master/algorithms/compiled.py): a step split into
many chunks gives, with components frozen one after another, the analytic values and the reference step's rows
bit for bit, and each rebuild compiles again only the chunk that lost a component (a fleet of 256 UAVs rebuilt
its whole step at every landing)."""
import numpy as np
import pytest
from lxml import etree

import master
from master.algorithms import compiled
from master.monitors import Monitor, register
from master.ssp.writer import SspBuilder

TYPE = "org.example.freeze-at"
N = 12                                       # integrators i0..i11, each y = t until it is frozen
FREEZE = {"i1": 0.3, "i6": 0.5, "i7": 0.5, "i10": 0.8}      # component -> time after which it stops stepping


@register(TYPE)
class FreezeAt(Monitor):
    """Takes each component named in ``plan`` ("name:time ...") out after the step that reaches its time."""

    def __init__(self, element, plan, shown_as):
        super().__init__(element, plan, shown_as)
        self.plan = [(name, float(t)) for name, t in (p.split(":") for p in element[0].get("plan").split())]

    def after_step(self, n, t0, t1):
        due = [name for name, t in self.plan if t1 >= t - 1e-9]
        if due:
            self.plan = [(name, t) for name, t in self.plan if name not in due]
            self.ctx.deactivate(due)


def _ssp(tmp_path, fmu):
    b = SspBuilder("freeze", stop=1.0, step=0.1)
    b.add_component("one", fmu, params={"x0": 1.0})           # u = 0: one.y = 1
    for k in range(N):
        b.add_component(f"i{k}", fmu)
        b.connect("one", "y", f"i{k}", "u")
    ann = etree.Element("{http://ssp-standard.org/SSP1/SystemStructureCommon}Annotation", type=TYPE)
    etree.SubElement(ann, "{https://example.org/freeze}FreezeAt", plan=" ".join(f"{c}:{t}" for c, t in FREEZE.items()))
    b.annotations.append(ann)
    return b.write(tmp_path / "freeze.ssp")


def _run(ssp, out, algorithm):
    return master.run(ssp, output=out, algorithm=algorithm, record=["i*.y"])


@pytest.mark.parametrize("algorithm", ["jacobi", "gauss-seidel"])
@pytest.mark.parametrize("kind", ["c2", "py"])
def test_chunked_step_with_components_taken_out(tmp_path, test_fmus, monkeypatch, algorithm, kind):
    ssp = _ssp(tmp_path, test_fmus[f"{kind}:Integrator"])
    monkeypatch.setattr(compiled, "CHUNK_LINES", 6)       # one to a few components per chunk
    compiled._CODE_CACHE.clear()
    parts = []
    make_part = compiled._part

    def counted_part(c, lines, name, out):
        parts.append(c)
        return make_part(c, lines, name, out)
    monkeypatch.setattr(compiled, "_part", counted_part)
    builds = []         # per build: (its blocks' keys, the layout's chunk of each key, the chunks made, chunks used)
    assemble = compiled._assemble

    def counted_assemble(ns, blocks, name, out, memo):
        done = len(parts)
        fn = assemble(ns, blocks, name, out, memo)
        builds.append(({key for key, _ in blocks}, dict(memo["chunk_of"]), parts[done:], fn.source.count("def _part")))
        return fn
    monkeypatch.setattr(compiled, "_assemble", counted_assemble)
    got = _run(ssp, tmp_path / "compiled", algorithm).frame

    t = got["time"].to_numpy()
    for k in range(N):              # y = t, then held at the time of the step after which it was taken out
        want = np.minimum(t, FREEZE.get(f"i{k}", np.inf))
        np.testing.assert_allclose(got[f"i{k}.y"].to_numpy(), want, atol=1e-12, err_msg=f"i{k}")
    # the first build makes every chunk; each of the three rebuilds (after 0.3, 0.5 and 0.8 s) only the chunks
    # that held a block of the components it took out (and still hold others: an emptied chunk is left out)
    assert len(builds) == 4
    _, _, made, chunks = builds[0]
    assert chunks >= 6 and sorted(made) == list(range(chunks))
    for (before, layout, _, _), (now, _, made, _) in zip(builds, builds[1:]):
        lost = {layout[key] for key in before - now}
        assert 1 <= len(lost) <= 2 and sorted(made) == sorted(lost & {layout[key] for key in now})

    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "1")      # the reference step
    want = _run(ssp, tmp_path / "reference", algorithm).frame
    assert got.equals(want)
    for c in got.columns:
        assert got[c].to_numpy().tobytes() == want[c].to_numpy().tobytes(), c


@pytest.mark.parametrize("algorithm", ["jacobi", "gauss-seidel"])
@pytest.mark.parametrize("kind", ["c2", "py"])
def test_a_failure_in_a_later_chunk_keeps_the_counts_and_rows_of_the_reference(tmp_path, test_fmus, monkeypatch,
                                                                                algorithm, kind):
    """A component in the middle of a chunked step fails after rebuilds: the error, the rows kept and the doStep
    counts (the deferred counts of the chunks before it and of its own chunk up to it) are the reference's."""
    b = SspBuilder("fail", stop=1.0, step=0.1)
    b.add_component("one", test_fmus[f"{kind}:Integrator"], params={"x0": 1.0})
    for k in range(N):
        b.add_component(f"i{k}", test_fmus[f"{kind}:Integrator"])
        b.connect("one", "y", f"i{k}", "u")
        if k == 6:       # fails in the step that ends after 0.65 s
            b.add_component("bad", test_fmus[f"{kind}:Faulty"], params={"fail_time": 0.65, "mode": 1})
    ann = etree.Element("{http://ssp-standard.org/SSP1/SystemStructureCommon}Annotation", type=TYPE)
    etree.SubElement(ann, "{https://example.org/freeze}FreezeAt", plan="i1:0.3 i9:0.5")
    b.annotations.append(ann)
    ssp = b.write(tmp_path / "fail.ssp")
    monkeypatch.setattr(compiled, "CHUNK_LINES", 6)

    def run(name):
        r = master.run(ssp, output=tmp_path / name, algorithm=algorithm, record=["i*.y"], raise_on_error=False)
        return r.frame, r.metadata
    got, got_meta = run("compiled")
    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "1")
    want, want_meta = run("reference")
    assert got_meta["outcome"] == want_meta["outcome"] == "error"
    assert "bad" in got_meta["error"] and got_meta["error"] == want_meta["error"]
    assert got_meta["fmu_calls"] == want_meta["fmu_calls"]
    assert got_meta["fmu_calls"]["do_step"]["i0"] == 7 and got_meta["fmu_calls"]["do_step"]["i1"] == 3
    assert got.equals(want) and len(got) == 7          # rows at 0 .. 0.6 s
