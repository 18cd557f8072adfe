// The dashboard's plotly.js: the core (with the scatter trace) and the other trace types the dashboard
// draws. TRACES in build.sh lists them, and tests/frontend/test_plotly_bundle.py checks that no view needs
// another; add a trace type there and here together, then run build.sh.
'use strict';

var Plotly = require('plotly.js/lib/core');

Plotly.register([
    require('plotly.js/lib/bar'),
    require('plotly.js/lib/heatmap'),
]);

module.exports = Plotly;
