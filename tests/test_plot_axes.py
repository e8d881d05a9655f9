"""The plots show units scaled to an SI prefix, never an offset or power-of-ten text beside the ticks, the
data's name in the title and the truth dashed where it is known (issue 21). Figures are drawn to PNG files in
a temporary directory and their Axes inspected."""
import re
import subprocess

import numpy as np
import pytest
from matplotlib.figure import Figure
from ros_isolation import REPO, VENV_BIN

from emla_cli import identify_plot
from emla_cli.cli import main
from emla_core.plot_axes import si_axis, si_unit


@pytest.mark.parametrize('unit, magnitude, factor, shown', [
    ('H', 2.1e-3, 1e3, 'mH'), ('H', 1.6, 1.0, 'H'), ('ohm', 4.0, 1.0, 'ohm'), ('ohm', 4.0e3, 1e-3, 'kohm'),
    ('m', 3e-6, 1e6, 'µm'), ('N', 0.02, 1e3, 'mN'), ('kg', 0.036, 1e3, 'g'), ('kg', 2.5, 1.0, 'kg'),
    ('kg', 2e-5, 1e6, 'mg'), ('V s/m', 10.8, 1.0, 'V s/m'), ('A/V', 0.044, 1e3, 'mA/V'), ('-', 1e-4, 1.0, '-'),
    ('[y]/[u]', 1e-4, 1.0, '[y]/[u]'), ('H', 0.0, 1.0, 'H'), ('H', float('nan'), 1.0, 'H'),
])
def test_si_unit_puts_the_values_between_1_and_1000(unit, magnitude, factor, shown):
    assert si_unit(unit, magnitude) == (pytest.approx(factor), shown)


def ticks(ax, which='y'):
    """[(tick location, its label as a number)] of the drawn axis, inside the view."""
    axis = ax.yaxis if which == 'y' else ax.xaxis
    low, high = sorted(ax.get_ylim() if which == 'y' else ax.get_xlim())
    return [(tick.get_loc(), float(tick.label1.get_text().replace('−', '-')))
            for tick in axis.get_major_ticks() if low <= tick.get_loc() <= high and tick.label1.get_text()]


def drawn(fig, tmp_path):
    fig.savefig(tmp_path / 'figure.png', format='png')
    assert (tmp_path / 'figure.png').stat().st_size > 5_000
    return fig.axes


def assert_plain(ax):
    assert ax.yaxis.get_offset_text().get_text() == ''
    assert ax.xaxis.get_offset_text().get_text() == ''


def test_a_narrow_range_far_from_zero_shows_no_offset(tmp_path):
    time = np.linspace(0.0, 0.3, 300)
    values = 4.0 + 2e-5 * np.sin(40 * time)          # R within +-20 uohm of 4 ohm
    control = Figure().add_subplot()
    control.plot(time, values)
    control.figure.savefig(tmp_path / 'control.png')
    assert control.yaxis.get_offset_text().get_text() != ''   # matplotlib alone writes an offset here
    fig = Figure()
    ax = fig.add_subplot()
    ax.plot(time, values)
    si_axis(ax, 'y', 'resistance R', 'ohm')
    (ax,) = drawn(fig, tmp_path)
    assert_plain(ax)
    pairs = ticks(ax)
    assert len(pairs) >= 3 and all(label == pytest.approx(loc, abs=1e-9) for loc, label in pairs)


def test_stamps_since_1970_count_from_the_first(tmp_path):
    start = 1.7e9
    fig = identify_plot.convergence_figure(start + np.linspace(0, 0.5, 50), {'resistance': np.full(50, 4.0)},
                                           {'resistance': np.full(50, 0.01)}, title='x.csv: full model')
    (ax,) = drawn(fig, tmp_path)
    assert_plain(ax)
    assert ax.get_xlabel() == 'time (ms) from 1700000000 s'
    assert all(label == pytest.approx((loc - start) * 1e3, abs=1e-3) for loc, label in ticks(ax, 'x'))


def test_the_convergence_figure(tmp_path):
    time = np.linspace(0.0, 2.0, 200)
    drift = 1 + 1e-4 * np.cos(3 * time)
    truth = {'resistance': 4.0, 'inductance': 1.6e-3, 'mass': 0.036}
    estimates = {name: value * drift for name, value in truth.items()}
    std = {name: 1e-5 * value * np.ones_like(time) for name, value in truth.items()}
    fig = identify_plot.convergence_figure(time, estimates, std, truth, title='bench_3.csv: full model')
    axes = drawn(fig, tmp_path)
    assert 'bench_3.csv' in fig.get_suptitle()
    labels = {ax.get_ylabel(): ax for ax in axes}
    assert set(labels) == {'resistance R (ohm)', 'inductance L (mH)', 'mass m (g)'}
    for label, factor in (('resistance R (ohm)', 1.0), ('inductance L (mH)', 1e3), ('mass m (g)', 1e3)):
        ax = labels[label]
        assert_plain(ax)
        pairs = ticks(ax)
        assert len(pairs) >= 2 and all(shown == pytest.approx(loc * factor, rel=1e-9) for loc, shown in pairs)
    for name, ax in zip(truth, axes, strict=True):
        dashed = [line for line in ax.get_lines() if line.get_linestyle() == '--']
        assert len(dashed) == 1 and dashed[0].get_ydata()[0] == truth[name]
    assert axes[-1].get_xlabel() == 'time (s)'


@pytest.fixture(scope='module')
def simulated(tmp_path_factory):
    """A bag of `emla simulate` (it carries the true parameters)."""
    bag = tmp_path_factory.mktemp('sim') / 'table1_run'
    out = subprocess.run([str(VENV_BIN / 'emla'), 'simulate', 'default', '--duration', '0.3', '--bag', str(bag)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return bag


def identify_figure(monkeypatch, tmp_path, *args):
    """The Figure `emla identify ... --plot` draws (run in this process), once it is written."""
    figures = []
    original = identify_plot.convergence_figure

    def keep(*a, **kw):
        figures.append(original(*a, **kw))
        return figures[-1]
    monkeypatch.setattr(identify_plot, 'convergence_figure', keep)
    png = tmp_path / 'identify.png'
    assert main(['identify', *map(str, args), '--plot', str(png), '--json', str(tmp_path / 'r.json')]) == 0
    assert png.stat().st_size > 10_000 and len(figures) == 1
    return figures[0]


def test_identify_plot_of_a_simulated_bag(monkeypatch, tmp_path, simulated):
    fig = identify_figure(monkeypatch, tmp_path, simulated)
    assert fig.get_suptitle().startswith('table1_run')
    for ax in fig.axes:
        assert_plain(ax)
        assert re.fullmatch(r'.+ \((µ|m|k)?(ohm|H|V s/m|g|N s/m|N)\)', ax.get_ylabel()), ax.get_ylabel()
        # the simulated bag carries its true values: each panel has its dashed line
        assert [line for line in ax.get_lines() if line.get_linestyle() == '--'], ax.get_ylabel()


def test_identify_plot_of_an_arx_model(monkeypatch, tmp_path, simulated):
    fig = identify_figure(monkeypatch, tmp_path, simulated, '--model', 'arx', '--orders', '2', '2', '1')
    assert fig.get_suptitle() == 'table1_run: ARX(2, 2, 1) from voltage to current'
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels[:2] == ['a1 (-)', 'a2 (-)'] and all(re.fullmatch(r'b\d \((m|µ)?A/V\)', b) for b in labels[2:])
    for ax in fig.axes:
        assert_plain(ax)


EXAMPLE = REPO / 'bags' / 'example_discrepancy'


@pytest.fixture
def kept_figures(monkeypatch):
    """The figures pyplot closes (the commands close theirs once written), kept open to inspect."""
    import matplotlib.pyplot as plt
    figures = []
    monkeypatch.setattr(plt, 'close', figures.append)
    yield figures
    for figure in figures:
        figure.clear()


def assert_labelled(ax):
    """No offset text; every labelled axis names a unit in brackets."""
    assert_plain(ax)
    for label in (ax.get_xlabel(), ax.get_ylabel()):
        assert not label or re.search(r'\((µ|m|k)?[A-Za-z/ -]+\)', label), label


def test_the_discrepancy_report_and_compare_figures(tmp_path, kept_figures):
    model = tmp_path / 'm.yaml'
    assert main(['discrepancy', str(EXAMPLE), '--json', str(tmp_path / 'd.json'), '--report', str(tmp_path / 'r'),
                 '--model-out', str(model)]) == 0
    assert len(kept_figures) == 4                      # gap, residuals, correlation, disagreement
    assert main(['compare', str(EXAMPLE), '--model-file', str(model), '--plot', str(tmp_path / 'c.png'),
                 '--json', str(tmp_path / 'c.json')]) == 0
    assert len(kept_figures) == 5 and (tmp_path / 'c.png').stat().st_size > 10_000
    for figure in kept_figures:
        assert figure.get_suptitle().startswith('example_discrepancy')
        for ax in figure.axes:
            assert_labelled(ax)
    gap, compare = kept_figures[0], kept_figures[4]
    for figure in (gap, compare):   # position in mm, its prediction error in um or mm, time in ms or s
        labels = [ax.get_ylabel() for ax in figure.axes]
        assert 'position (mm)' in labels and 'current (A)' in labels, labels
        assert all(re.fullmatch(r'time \((m)?s\)', ax.get_xlabel()) for ax in figure.axes[2:]), labels
