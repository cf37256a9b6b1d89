// Runs of f a second, for the proxy bench's Node scripts: the median over
// batches of at least 5 ms each, for half a second of batches in all (as
// proxy.rs's median_rate: a mean over the whole half second would count the
// machine's pauses too).
'use strict';
module.exports = function medianRate(f) {
  const now = () => Number(process.hrtime.bigint()) / 1e9;
  const start = now();
  const rates = [];
  while (rates.length < 3 || now() - start < 0.5) {
    const t = now();
    let runs = 0;
    while (runs === 0 || now() - t < 0.005) {
      f();
      runs++;
    }
    rates.push(runs / (now() - t));
  }
  rates.sort((a, b) => a - b);
  return rates[rates.length >> 1];
};
