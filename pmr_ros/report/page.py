"""The Jinja2 template of the HTML report (one self-contained page; figures are ``data:`` URIs)."""

from __future__ import annotations

__all__ = ["TEMPLATE"]

TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{{ title }}</title>
<style>
 body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto; max-width: 1100px;
        padding: 1.2em; color: #212121; line-height: 1.4; }
 h1 { font-size: 1.6em; margin-bottom: 0.2em; }
 h2 { border-bottom: 2px solid #e0e0e0; padding-bottom: 0.2em; margin-top: 1.6em; }
 .meta { color: #616161; }
 .badge { display: inline-block; padding: 0.1em 0.6em; border-radius: 0.8em; color: white; font-weight: 600; }
 .counts span { margin-right: 1.2em; }
 table { border-collapse: collapse; margin: 0.6em 0; }
 th, td { border: 1px solid #e0e0e0; padding: 0.3em 0.6em; text-align: left; vertical-align: top; }
 th { background: #fafafa; }
 td.num { text-align: right; font-variant-numeric: tabular-nums; }
 figure { margin: 0.8em 0; }
 figure img { max-width: 100%; height: auto; border: 1px solid #eeeeee; }
 figcaption { color: #616161; font-size: 0.9em; }
 .element { border-left: 6px solid; padding-left: 1em; margin: 1.4em 0; }
 .reasons li { color: #8d6e00; }
 .warnings li { color: #616161; }
 .pair { display: flex; flex-wrap: wrap; gap: 1em; align-items: flex-start; }
 .pair figure { flex: 1 1 480px; }
 .note { background: #f5f5f5; padding: 0.6em 1em; border-radius: 0.4em; font-size: 0.92em; }
</style>
</head>
<body>
<h1>{{ title }}</h1>
<p class="meta">
 {{ report.get("source", report.get("config")) }} &middot; method {{ diagnosis.method }} &middot;
 {{ diagnosis.samples }} samples diagnosed in {{ stretches }} unbroken stretch(es) &middot;
 sample time {{ sample_time }} &middot; pmr_ros {{ report.version }}
</p>
{% if report.get("windows") %}
<p class="note">The last of {{ report.windows|length }} rolling windows ({{ report.monitor.window }} stepped by
 {{ report.monitor.step }}): <a href="trend.html">the trend over every window, with the onsets</a>.</p>
{% endif %}
{% if diagnosis.status != "ok" %}
<p class="badge" style="background: {{ colours.inconclusive }}">no verdict: {{ diagnosis.reason }}</p>
{% endif %}
<p class="counts">
 <span class="badge" style="background: {{ colours.mismatch }}">{{ counts.mismatch }} mismatch</span>
 <span class="badge" style="background: {{ colours.inconclusive }}">{{ counts.inconclusive }} inconclusive</span>
 <span class="badge" style="background: {{ colours.ok }}">{{ counts.ok }} ok</span>
</p>

<h2 id="overview">The controller at a glance</h2>
<figure><img src="{{ matrix.data_uri }}" alt="{{ matrix.caption }}"><figcaption>{{ matrix.caption }}:
 rows are the controlled variables (CVs), columns the manipulated variables (MVs).</figcaption></figure>

{% if impact %}
<h2 id="impact">Which mismatch matters for control</h2>
<p class="note">The {{ "configured PI loops" if report.get("controller") == "pi" else "configured MPC" }} simulated
 (noise-free, the configured setpoint excitation) on the plant as
 estimated, against the same loop on the plant as modelled: the ratio of the integrated squared tracking error (ISE)
 and of the squared input moves, {{ "every controlled CV and every MV alike" if report.get("controller") == "pi"
 else "both weighted as the MPC weighs them" }}. 1 means the mismatch does not matter for
 control; the estimates stand for the plant, their intervals are not propagated.</p>
<table><tr><th>rank</th><th>element</th><th>ISE ratio, this mismatch alone</th><th>input moves ratio</th></tr>
{% for row in impact %}<tr><td>{{ row.rank }}</td><td><a href="#{{ row.name }}">{{ row.name }}</a></td>
 <td>{{ "%.2f"|format(row.ise) }}</td><td>{{ "%.2f"|format(row.moves) }}</td></tr>{% endfor %}
{% if impact_all %}<tr><td></td><td>all together</td><td>{{ "%.2f"|format(impact_all.ise_ratio) }}</td>
 <td>{{ "%.2f"|format(impact_all.input_movement_ratio) }}</td></tr>{% endif %}
</table>
{% elif report.get("impact_note") %}
<h2 id="impact">Which mismatch matters for control</h2>
<p class="note">{{ report.impact_note }}</p>
{% endif %}

<h2 id="elements">Element by element</h2>
<p class="note">Each figure shows the plant-model ratio G/Ĝ of one element against frequency: the spectral
 estimate (blue) with its {{ "%.0f"|format(level) }} % confidence band (shaded blue; at each frequency on its own),
 the fitted ratio (red, dashed: the model element scaled in gain, speed and delay) whose numbers give the
 verdict, and the &ldquo;no mismatch&rdquo; line
 (|G/Ĝ| = 1, phase 0). Only the informative band (light blue background: where the coherence of the row with
 the setpoints holds) carries information; beyond it the estimate is noise. A gain mismatch moves the curve at low
 frequency, a time-constant mismatch bends it, a delay mismatch turns the phase.</p>
{% for notes, figure in elements %}
<section class="element" style="border-color: {{ notes.colour }}" id="{{ notes.name }}">
 <h3>{{ notes.name }} <span class="badge" style="background: {{ notes.colour }}">{{ notes.verdict }}</span></h3>
 <p>{{ notes.summary }}</p>
 {% if notes.impact %}<p>Control impact of this mismatch alone: ISE &times;{{ "%.2f"|format(notes.impact.ise_ratio) }},
 input moves &times;{{ "%.2f"|format(notes.impact.input_movement_ratio) }}
 (rank {{ notes.impact.rank }}).</p>{% endif %}
 {% if notes.absolute %}<table class="absolute">
 <tr>{% for h in notes.absolute.header %}<th>{{ h }}</th>{% endfor %}</tr>
 {% for row in notes.absolute.rows %}<tr><td>{{ row[0] }}</td>{% for cell in row[1:] %}<td class="num">{{ cell }}</td>
 {% endfor %}</tr>{% endfor %}</table>{% endif %}
 {% if notes.reasons %}<p>Why the data cannot tell (add excitation here):</p>
 <ul class="reasons">{% for reason in notes.reasons %}<li>{{ reason }}</li>{% endfor %}</ul>{% endif %}
 {% if notes.warnings %}<ul class="warnings">{% for warning in notes.warnings %}<li>{{ warning }}</li>{% endfor %}</ul>
 {% endif %}
 <div class="pair">
 {% if figure %}<figure><img src="{{ figure.data_uri }}" alt="{{ figure.caption }}">
 <figcaption>{{ figure.caption }}</figcaption></figure>{% endif %}
 {% if notes.step %}<figure><img src="{{ notes.step.data_uri }}" alt="{{ notes.step.caption }}">
 <figcaption>{{ notes.step.caption }}</figcaption></figure>{% endif %}
 {% if notes.shape %}<figure class="shape"><img src="{{ notes.shape.data_uri }}" alt="{{ notes.shape.caption }}">
 <figcaption>{{ notes.shape.caption }}</figcaption></figure>{% endif %}
 </div>
</section>
{% endfor %}

<h2 id="data">The data and their cleaning</h2>
<p class="meta">{{ data.source }}, from {{ data.start }}, {{ data.samples }} samples of {{ data.sample_time_s }} s.</p>
<table>
 <tr><th>step</th><th>count</th><th>detail</th></tr>
 {% for step in steps %}<tr><td>{{ step.name }}</td><td class="num">{{ step.count }} {{ step.unit }}</td>
 <td>{{ step.detail }}</td></tr>{% endfor %}
</table>
<figure><img src="{{ timeline.data_uri }}" alt="{{ timeline.caption }}"><figcaption>{{ timeline.caption }}.
</figcaption></figure>
{% if prediction %}<h2 id="prediction">Measured against predicted</h2>
<figure><img src="{{ prediction.data_uri }}" alt="{{ prediction.caption }}"><figcaption>{{ prediction.caption }}.
</figcaption></figure>{% endif %}
</body>
</html>
"""
