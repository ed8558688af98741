"""The GIF writer: delays in the GIF's 10 ms unit, the last picture held; read back from files."""

from __future__ import annotations

import numpy as np
import pytest
from gif_helpers import gif_delays
from hypothesis import given
from hypothesis import strategies as st

from planar3p_agents.evaluation.episode_gif import frame_delay_ms, write_gif


def _frames(n: int, still_from: int | None = None) -> list[np.ndarray]:
    """``n`` 16x16 frames, each different from the one before, except that from frame
    ``still_from`` on they repeat (a machine at rest)."""
    frames = []
    for i in range(n):
        k = i if still_from is None else min(i, still_from)
        f = np.zeros((16, 16, 3), np.uint8)
        f[k % 16, (k // 16) % 16] = 255
        frames.append(f)
    return frames


@given(st.sampled_from([50 / 3, 25.0, 50.0, 12.5, 10.0, 5.0]))
def test_frame_delay_is_the_rate_in_whole_10_ms(fps):
    """50/3 frames/s is 60 ms (1000 / (50/3) is 59.99... in floating point, which the GIF's
    truncation would store as 50 ms)."""
    d = frame_delay_ms(fps)
    assert d % 10 == 0
    assert d == pytest.approx(1000.0 / fps, abs=5.0)


def test_frame_delay_refuses_a_rate_not_above_zero():
    with pytest.raises(ValueError, match="fps"):
        frame_delay_ms(0.0)


def test_written_delays_read_back(tmp_path):
    """Every frame is shown 1000 / fps ms (not 0: seconds given where Pillow takes ms), the last
    one 1 s longer; the GIF loops."""
    path = tmp_path / "a.gif"
    written = write_gif(path, _frames(7), fps=50 / 3)
    assert written == [60] * 6 + [1060]
    delays, loop = gif_delays(path)
    assert delays == written
    assert loop == 0


def test_identical_frames_keep_their_time(tmp_path):
    """Pillow merges identical consecutive frames; their delays add up, so the animation lasts
    as long as the frames given (here 10 frames, the last 5 alike, at 25 frames/s, held 0.5 s)."""
    path = tmp_path / "b.gif"
    write_gif(path, _frames(10, still_from=5), fps=25.0, hold_s=0.5)
    delays, _ = gif_delays(path)
    assert len(delays) == 6
    assert sum(delays) == 10 * 40 + 500
    assert delays[-1] == 5 * 40 + 500


def test_bad_input_writes_nothing(tmp_path):
    path = tmp_path / "c.gif"
    with pytest.raises(ValueError, match="no frames"):
        write_gif(path, [], fps=25.0)
    with pytest.raises(ValueError, match="hold_s"):
        write_gif(path, _frames(2), fps=25.0, hold_s=-1.0)
    with pytest.raises(ValueError, match="fps"):
        write_gif(path, _frames(2), fps=-1.0)
    assert not path.exists()
