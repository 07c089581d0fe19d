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
