# Fetches the page's plotting library (uPlot, pinned by web/package-lock.json) with `npm ci` and copies its
# files next to the page. Run at build time (services/view/CMakeLists.txt), never at run time. Without npm or
# the npm registry the build goes on: the viewer then serves the page without plots and says why.
# -D SRC=<web dir> -D WORK=<scratch dir> -D OUT=<the page's dir> -D STAMP=<file written on success>
file(MAKE_DIRECTORY ${WORK} ${OUT})
file(COPY ${SRC}/package.json ${SRC}/package-lock.json DESTINATION ${WORK})
find_program(NPM npm)
if(NOT NPM)
  message(WARNING "tandem view: npm not found; the page will have no plots (install nodejs and npm, then rebuild)")
  return()
endif()
execute_process(COMMAND ${NPM} ci --no-audit --no-fund --loglevel=error WORKING_DIRECTORY ${WORK}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 300)
if(NOT rc EQUAL 0)
  message(WARNING "tandem view: npm ci failed (${rc}); the page will have no plots\n${err}")
  return()
endif()
file(COPY ${WORK}/node_modules/uplot/dist/uPlot.iife.min.js ${WORK}/node_modules/uplot/dist/uPlot.min.css
     ${WORK}/node_modules/uplot/LICENSE DESTINATION ${OUT})
file(TOUCH ${STAMP})
