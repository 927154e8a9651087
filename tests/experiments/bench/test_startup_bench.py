"""`make bench`'s start-up entry: each command really runs in a process of its own, and the render's
whole process contains the render its image records."""
from drtlab.experiments.bench.startup import COMMANDS, startup


def test_startup_times_each_command_around_the_render_it_records():
    s = startup(1)
    assert s["repeats"] == 1
    assert 0 <= s["render_launch_seconds"] <= s["render_in_process_seconds"]
    assert s["render_compile_seconds"] <= s["render_in_process_seconds"]
    assert 0 < s["beyond_render_seconds"] < s["render_whole_process_seconds"]
    assert abs(s["render_whole_process_seconds"] - s["render_in_process_seconds"]
               - s["beyond_render_seconds"]) <= 0.002            # one run: rounding only
    assert set(s["whole_process_seconds"]) == set(COMMANDS)
    assert all(t > 0 for t in s["whole_process_seconds"].values())
