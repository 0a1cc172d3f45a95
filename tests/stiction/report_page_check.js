// Opens the plant report page in Debian's chromium (playwright-core), as an engineer would:
// the page loads without errors, the table sorts by a click on a header, a click on a loop opens
// its section, the filter hides rows; prints what it saw as JSON and keeps two screenshots.
// usage: node report_page_check.js PAGE.html SHOT_PREFIX
const { chromium } = require(process.env.PW_CORE);
(async () => {
  const browser = await chromium.launch({ executablePath: '/usr/bin/chromium', headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
           '--disable-component-update', '--disable-sync'] });
  const page = await browser.newPage({ viewport: { width: 1300, height: 900 } });
  const errors = [];
  const requests = [];
  page.on('pageerror', e => errors.push(String(e)));
  page.on('console', m => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('request', r => { if (!r.url().startsWith('file:') && !r.url().startsWith('data:')) requests.push(r.url()); });
  await page.goto('file://' + process.argv[2]);
  const out = { errors, requests };
  const ranks = () => page.$$eval('#loops tbody tr', rows => rows.map(r => r.cells[0].textContent.trim()));
  const column = (k) => page.$$eval('#loops tbody tr', (rows, k) => rows.map(r => r.cells[k].dataset.value || ''), k);
  out.rows = (await ranks()).length;
  // sort by S (column 4): descending after two clicks
  await page.click('#loops thead th:nth-child(5)');
  out.s_ascending = await column(4);
  await page.click('#loops thead th:nth-child(5)');
  out.s_descending = await column(4);
  await page.click('#loops thead th:nth-child(1)');
  out.ranks_after = await ranks();
  await page.screenshot({ path: process.argv[3] + '-table.png' });
  // open the first loop's section from the table
  const first = await page.$('#loops tbody tr a.open');
  const href = await first.getAttribute('href');
  await first.click();
  out.opened = await page.$eval(href, el => el.open);
  out.opened_has_figure = await page.$eval(href, el => {
    const img = el.querySelector('img');
    return img !== null && img.complete && img.naturalWidth > 100;
  });
  await page.screenshot({ path: process.argv[3] + '-loop.png' });
  // filter by verdict
  await page.selectOption('#verdict', 'stiction');
  out.visible_after_filter = await page.$$eval('#loops tbody tr', rows => rows.filter(r => r.style.display !== 'none')
    .map(r => r.dataset.verdict));
  console.log(JSON.stringify(out));
  await browser.close();
})().catch(e => { console.error(e); process.exit(1); });
