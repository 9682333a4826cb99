// three.js ships as ES modules that import one another by name; a page on
// file:// cannot fetch them, so their sources sit in this page as inert
// text and are handed to the browser as blob URLs through an import map,
// which must be in place before the page's own module script is reached.
(function () {
  function moduleUrl(id) {
    var text = document.getElementById(id).textContent;
    return URL.createObjectURL(new Blob([text], { type: 'text/javascript' }));
  }
  var map = document.createElement('script');
  map.type = 'importmap';
  map.textContent = JSON.stringify({
    imports: {
      'three/core': moduleUrl('three-core-src'),
      'three': moduleUrl('three-module-src'),
      'three/addons/controls/OrbitControls.js': moduleUrl('three-orbit-src')
    }
  });
  document.currentScript.after(map);
})();
