"""DeferredSink: every report hook of Sink is held and replayed in order; nothing reaches the
real sink before replay()."""

import inspect

from vs_inspect.record.sink import REPORT_HOOKS, DeferredSink, Sink


class _Recorder(Sink):
    def __init__(self):
        self.calls = []


for _name in REPORT_HOOKS:
    setattr(_Recorder, _name, lambda self, *a, _n=_name, **k: self.calls.append((_n, a, k)))


def test_every_report_hook_is_held_and_replayed_in_order():
    hooks = {n for n, f in inspect.getmembers(Sink, inspect.isfunction) if not n.startswith("_")}
    # every hook but the query and the end of the recording is a report
    assert set(REPORT_HOOKS) == hooks - {"image_frames", "close", "abort"}
    assert {"pair_votes", "stage_event", "cameras", "pair_matches", "run_summary"} <= set(REPORT_HOOKS)
    held, real = DeferredSink(None), _Recorder()
    sent = [(name, (i, f"x{i}"), {"k": i}) for i, name in enumerate(reversed(REPORT_HOOKS))]
    for name, args, kwargs in sent:
        getattr(held, name)(*args, **kwargs)
    assert real.calls == []
    held.replay(real)
    assert real.calls == sent
    again = _Recorder()
    held.replay(again)  # replay does not use the reports up
    assert again.calls == sent
